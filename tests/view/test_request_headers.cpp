// The Host and Content-Type headers handscs-view's server accepts (view/request_headers.h): exact
// loopback names and ports, and application/json with or without parameters; names and types
// that only start like one are refused.
#include "catch_torch.h"

#include <string>
#include <vector>

#include "view/request_headers.h"

TEST_CASE("view request headers: loopback hosts and Host headers match exactly") {
  for (const std::string host : {"127.0.0.1", "127.255.0.9", "localhost", "::1"}) {
    INFO(host);
    CHECK(handscs::is_loopback_host(host));
  }
  for (const std::string host : {"0.0.0.0", "128.0.0.1", "127.evil.com", "127.0.0.1.nip.io", "127.0.0.256",
                                 "127.0.0", "127.0.0.1.", "127..0.1", "1127.0.0.1", "localhost.evil.com", ""}) {
    INFO(host);
    CHECK_FALSE(handscs::is_loopback_host(host));
  }
  for (const std::string header : {"127.0.0.1", "127.0.0.1:8080", "127.8.9.10:1", "localhost", "localhost:80",
                                   "[::1]", "[::1]:8080"}) {
    INFO(header);
    CHECK(handscs::is_loopback_host_header(header));
  }
  for (const std::string header :
       {"127.evil.com", "127.evil.com:8080", "127.0.0.1.nip.io", "127.0.0.1.nip.io:8080", "127.0.0.300:8080",
        "127.0.0.1:", "127.0.0.1:80a", "127.0.0.1:123456", "127.0.0.1:80:80", "localhost.evil.com",
        "evil.example:80", "::1", "[::1]x", "[::1]:", "[::2]:80", "10.0.0.1:8080", ""}) {
    INFO(header);
    CHECK_FALSE(handscs::is_loopback_host_header(header));
  }
}

TEST_CASE("view request headers: POST bodies are application/json, not a type starting so") {
  for (const std::string type : {"application/json", "application/json; charset=utf-8",
                                 "application/json;charset=UTF-8", "application/json ;x=1"}) {
    INFO(type);
    CHECK(handscs::is_json_content_type(type));
  }
  for (const std::string type : {"application/jsonp-evil", "application/jsonp", "application/json-patch+json",
                                 "application/json5", "text/plain", "application/x-www-form-urlencoded",
                                 "application/jso", ""}) {
    INFO(type);
    CHECK_FALSE(handscs::is_json_content_type(type));
  }
}
