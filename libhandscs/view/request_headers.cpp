#include "view/request_headers.h"

#include <cctype>

#include "core/text.h"

namespace handscs {

namespace {

// A TCP port has at most 5 digits (65535); a longer run of digits is no port.
constexpr size_t kMaxPortDigits = 5;

// Four decimal octets of 0-255 separated by dots, the first 127.
bool is_loopback_dotted_quad(const std::string& host) {
  size_t start = 0;
  for (int octet = 0; octet < 4; ++octet) {
    const size_t end = octet < 3 ? host.find('.', start) : host.size();
    if (end == std::string::npos) return false;
    const std::string digits = host.substr(start, end - start);
    // Three digits hold every value of an octet (255).
    if (!all_digits(digits, 3) || std::stoi(digits) > 255) return false;
    if (octet == 0 && digits != "127") return false;
    start = end + 1;
  }
  return true;
}

}  // namespace

bool is_loopback_host(const std::string& host) {
  return host == "localhost" || host == "::1" || is_loopback_dotted_quad(host);
}

bool is_loopback_host_header(const std::string& header) {
  // The port follows the last ':', unless that ':' is inside "[::1]".
  const size_t colon = header.rfind(':'), bracket = header.rfind(']');
  const bool has_port = colon != std::string::npos && (bracket == std::string::npos || colon > bracket);
  const std::string host = has_port ? header.substr(0, colon) : header;
  if (has_port && !all_digits(header.substr(colon + 1), kMaxPortDigits)) return false;
  return host == "localhost" || host == "[::1]" || is_loopback_dotted_quad(host);
}

bool is_json_content_type(const std::string& value) {
  const std::string type = "application/json";
  if (value.compare(0, type.size(), type) != 0) return false;
  // Optional white space, then the end or the ';' that starts the parameters.
  size_t i = type.size();
  while (i < value.size() && (value[i] == ' ' || value[i] == '\t')) ++i;
  return i == value.size() || value[i] == ';';
}

}  // namespace handscs
