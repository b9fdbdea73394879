// handscs-view's server under malformed and hostile requests, and under concurrent and idle
// clients: every request gets a 4xx (or, for bytes that are not HTTP, the connection closed), the
// server still answers afterwards, and no reply is a 5xx. Prints what it tried.
#include "catch_torch.h"

#include <iostream>
#include <map>
#include <random>
#include <set>

#include <httplib.h>

#include "pose_text.h"
#include "raw_http.h"
#include "view_fixture.h"

namespace {

std::string post(const std::string& body, const std::string& type = "application/json",
                 const std::string& host = "127.0.0.1") {
  return "POST /api/render HTTP/1.1\r\nHost: " + host + "\r\nContent-Type: " + type +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
}

std::string get(const std::string& target) {
  return "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
}

bool answers(int port) {
  httplib::Client client("127.0.0.1", port);
  const auto reply = client.Get("/api/info");
  return reply && reply->status == 200;
}

}  // namespace

TEST_CASE("view fuzz: hostile requests get 4xx and the server keeps answering") {
  handscs_test::RunningServer s;
  struct Attempt {
    std::string name, bytes;
    std::set<int> expected;  // 0: closed without a reply
    bool half_close = false; // end the stream after the bytes (a request cut short)
  };
  std::mt19937 random(7);
  std::string garbage(2000, '\0');
  for (auto& c : garbage) c = static_cast<char>(random() & 0xff);
  const std::string nested = std::string(5000, '[') + std::string(5000, ']');
  const std::vector<Attempt> attempts = {
      {"binary garbage", garbage + "\r\n\r\n", {400, 0}},
      {"request line without a version", "GET /\r\n\r\n", {400, 0}},
      {"unknown method", "BREW / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n", {400, 404, 405}},
      {"header line of 20 KB", "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + std::string(20000, 'a') + "\r\n\r\n",
       {400, 413, 431, 0}},
      {"target of 20 KB", get("/" + std::string(20000, 'a')), {400, 414, 0}},
      {"path traversal", get("/../../../../etc/passwd"), {400, 404}},
      {"encoded path traversal", get("/%2e%2e/%2e%2e/etc/passwd"), {400, 404}},
      {"a folder of the server's", get("/api/"), {404}},
      {"a file name", get("/page.html"), {404}},
      {"GET on the render endpoint", get("/api/render"), {404, 405}},
      {"NUL in the path", get(std::string("/api/info\0/x", 12)), {400, 404}},
      {"POST as text/plain (no CORS preflight)", post("{}", "text/plain"), {415}},
      {"foreign Host (DNS rebinding)", post("{}", "application/json", "evil.example:80"), {403}},
      {"declared body of 100 MB", "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                                  "Content-Length: 100000000\r\n\r\n", {413}},
      {"negative Content-Length", "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                                  "Content-Length: -5\r\n\r\n{}", {400, 413, 0}},
      {"body shorter than declared", "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                                     "Content-Length: 500\r\n\r\n{\"held_out\"", {400, 0}, true},
      {"chunked body over the limit", "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
                                      "Transfer-Encoding: chunked\r\n\r\n" + std::string("8000\r\n") +
                                      std::string(0x8000, ' ') + "\r\n0\r\n\r\n", {400, 413, 0}},
      {"not JSON", post("{\"held_out\": "), {400}},
      {"JSON nested 5,000 deep", post(nested), {400}},
      {"number overflowing a double", post(R"({"controls": {"index.mcp": 1e999}})"), {400}},
      {"pose beyond the MANO bounds", post("{\"pose\": {\"pose\": " + handscs_test::pose_text({"0", "0", "1000"}) + "}}"), {400}},
      {"pose with a NaN (as a string)", post("{\"pose\": {\"pose\": " + handscs_test::pose_text({"\"NaN\""}) + "}}"), {400}},
      {"held-out pose that does not exist", post(R"({"held_out": 999})"), {400}},
      {"negative held-out index", post(R"({"held_out": -1})"), {400}},
      {"image of 4096 px", post(R"({"view": {"width": 4096, "height": 4096}})"), {400}},
      {"file path in the body", post(R"({"format": "../../etc/passwd"})"), {400}},
      {"unknown key", post(R"({"save_to": "/tmp/x"})"), {400}},
  };
  std::cout << "view fuzz: hostile requests (name: status; 0 = closed without a reply)\n";
  for (const auto& a : attempts) {
    const int status = handscs_test::raw_status(s.port, a.bytes, a.half_close);
    std::cout << "  " << a.name << ": " << status << "\n";
    INFO(a.name << ": status " << status);
    CHECK(a.expected.count(status) == 1);
    CHECK(answers(s.port));
  }

  // Random byte mutations of a valid body: each reply is 200 or 400, never a 5xx or a dropped one.
  const std::string valid = R"({"controls": {"index.mcp": 0.5, "thumb.flex": 0.2}, "view": {"yaw": 0.3, "width": 64, "height": 48}})";
  std::map<int, int> statuses;
  constexpr int kMutations = 200;
  for (int i = 0; i < kMutations; ++i) {
    std::string body = valid;
    const int edits = 1 + static_cast<int>(random() % 4);
    for (int e = 0; e < edits; ++e) body[random() % body.size()] = static_cast<char>(random() & 0xff);
    const int status = handscs_test::raw_status(s.port, post(body));
    ++statuses[status];
    INFO("mutated body " << i << ": status " << status);
    CHECK((status == 200 || status == 400));
  }
  std::cout << "view fuzz: " << kMutations << " randomly mutated render bodies:";
  for (const auto& [status, count] : statuses) std::cout << " " << count << " x " << status;
  std::cout << "\n";
  CHECK(answers(s.port));
}

TEST_CASE("view fuzz: idle and half-sent connections do not stop concurrent clients") {
  handscs::ViewServerConfig config;
  config.workers = 16;
  handscs_test::RunningServer s(config);
  // 8 connections that send nothing and 4 that stop halfway through a request, all held open.
  std::vector<int> idle;
  for (int i = 0; i < 8; ++i) idle.push_back(handscs_test::connect_loopback(s.port));
  for (int i = 0; i < 4; ++i) {
    const int fd = handscs_test::connect_loopback(s.port);
    const std::string half = "POST /api/render HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 100\r\n";
    ::send(fd, half.data(), half.size(), MSG_NOSIGNAL);
    idle.push_back(fd);
  }
  for (int fd : idle) CHECK(fd >= 0);
  // 4 clients at once, 5 frames each, every one with its own pose and view.
  std::vector<std::thread> clients;
  std::vector<int> ok(4, 0);
  for (int c = 0; c < 4; ++c)
    clients.emplace_back([&, c] {
      httplib::Client client("127.0.0.1", s.port);
      for (int k = 0; k < 5; ++k) {
        const std::string body = "{\"controls\": {\"index.mcp\": " + std::to_string(0.1 * k) +
                                 "}, \"view\": {\"yaw\": " + std::to_string(c) + ", \"width\": 96, \"height\": 64}}";
        const auto reply = client.Post("/api/render", body, "application/json");
        if (reply && reply->status == 200 && reply->body.size() > 100) ++ok[c];
      }
    });
  for (auto& t : clients) t.join();
  for (int c = 0; c < 4; ++c) CHECK(ok[c] == 5);
  for (int fd : idle) ::close(fd);
  CHECK(answers(s.port));
}
