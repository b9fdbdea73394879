// Which Host and Content-Type headers handscs-view's server accepts, as exact matches (a prefix
// match let a DNS-rebinding name "127.evil.com" and a type "application/jsonp" through).
#pragma once

#include <string>

namespace handscs {

// True for a loopback address or name as given to --host: a 127.0.0.0/8 dotted quad ("127.0.0.1",
// "127.1.2.3": four decimal octets of 0-255), "localhost" and "::1".
bool is_loopback_host(const std::string& host);

// True for a Host header that names a loopback host: a 127.0.0.0/8 dotted quad, "localhost" or
// "[::1]", each with an optional ":port" of digits ("127.0.0.1:8080"). Names that only start like
// one ("127.0.0.1.nip.io", "localhost.evil.com") are DNS names another party may point here.
bool is_loopback_host_header(const std::string& header);

// True for "application/json", alone or followed by ";" parameters ("application/json;
// charset=utf-8"); not for another type that starts so ("application/jsonp").
bool is_json_content_type(const std::string& value);

}  // namespace handscs
