// Include first in tests that use LibTorch: torch pulls in glog, whose CHECK macro would replace
// Catch2's; this includes torch, drops glog's CHECK, then includes Catch2.
#pragma once

#include <torch/types.h>

#include "catch_after_torch.h"
