// Catch2 for a test that includes LibTorch headers first: c10 pulls in glog, whose CHECK macro would
// replace Catch2's, so glog's is dropped before Catch2 comes in. Include it after the LibTorch
// headers (catch_torch.h does both).
#pragma once

#undef CHECK
#include <catch2/catch.hpp>
