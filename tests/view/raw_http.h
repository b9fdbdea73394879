// Raw loopback HTTP for hostile-request tests: bytes exactly as given (no client library to
// correct them), the reply's status line read back.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <string>

namespace handscs_test {

// A connected TCP socket to 127.0.0.1:port (-1 on failure); replies wait at most 10 s.
inline int connect_loopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  timeval timeout{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof(timeout));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// Sends `bytes` (then, with half_close, closes the sending side: the server sees the end of the
// stream) and returns the reply's status code once its header has arrived: 0 when the server
// closed the connection without a reply (or the reply was not HTTP).
inline int raw_status(int port, const std::string& bytes, bool half_close = false) {
  const int fd = connect_loopback(port);
  if (fd < 0) return -1;
  size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may close early (a body over the limit): read its reply
    sent += static_cast<size_t>(n);
  }
  if (half_close) ::shutdown(fd, SHUT_WR);
  std::string reply;
  char buffer[4096];
  for (ssize_t n; reply.find("\r\n\r\n") == std::string::npos && (n = ::recv(fd, buffer, sizeof(buffer), 0)) > 0;)
    reply.append(buffer, n);
  ::close(fd);
  if (reply.rfind("HTTP/1.", 0) != 0 || reply.size() < 12) return 0;
  return std::stoi(reply.substr(9, 3));
}

}  // namespace handscs_test
