#include "view/view_server.h"

#include <algorithm>
#include <cstdio>

#include <sys/socket.h>

#include <httplib.h>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "render/camera_json.h"
#include "view/pose_saver.h"
#include "view/request_headers.h"
#include "view/view_page.h"

namespace handscs {

namespace {

void send_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  // Messages may quote what the client sent: bytes that are not UTF-8 are replaced, not thrown on.
  res.set_content(json{{"error", message}}.dump(-1, ' ', false, json::error_handler_t::replace),
                  "application/json");
}

void send_json(httplib::Response& res, const json& value) {
  res.set_content(value.dump(), "application/json");
}

// Runs a POST handler on a parsed request; Error (the client's fault) -> 400, anything else -> 500.
template <class F>
httplib::Server::Handler post_handler(const OrbitView& default_view, F handle) {
  return [&default_view, handle](const httplib::Request& req, httplib::Response& res) {
    try {
      handle(parse_view_request(req.body, default_view), res);
    } catch (const Error& e) {
      send_error(res, 400, e.what());
    } catch (const std::exception& e) {
      spdlog::error("{} {}: {}", req.method, req.path, e.what());
      send_error(res, 500, "internal error (logged by the server)");
    }
  };
}

}  // namespace

ViewServer::ViewServer(ViewScene& scene, ViewServerConfig config)
    : scene_(scene), config_(std::move(config)), http_(std::make_unique<httplib::Server>()) {
  require(config_.workers >= 1, "--workers: at least 1");
  const int workers = config_.workers;
  http_->new_task_queue = [workers] { return new httplib::ThreadPool(workers); };
  // SO_REUSEADDR only (a restart binds while old connections linger in TIME_WAIT): httplib's default
  // also sets SO_REUSEPORT, under which a second server binds the same port without an error and
  // the kernel splits the connections between the two.
  http_->set_socket_options([](socket_t socket) {
    const int yes = 1;
    ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  http_->set_payload_max_length(kMaxViewRequestBytes);
  http_->set_read_timeout(config_.read_timeout_s, 0);
  http_->set_write_timeout(config_.read_timeout_s, 0);
  http_->set_keep_alive_timeout(config_.keep_alive_s);
  http_->set_default_headers({{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}});
  add_routes();
}

ViewServer::~ViewServer() = default;

void ViewServer::add_routes() {
  const bool loopback = is_loopback_host(config_.host);
  http_->set_pre_routing_handler([loopback](const httplib::Request& req, httplib::Response& res) {
    if (loopback && !is_loopback_host_header(req.get_header_value("Host"))) {
      send_error(res, 403, "Host " + req.get_header_value("Host") + " is not this loopback server");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.method == "POST" && !is_json_content_type(req.get_header_value("Content-Type"))) {
      send_error(res, 415, "POST bodies must be Content-Type: application/json");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  http_->set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;  // a handler's own error
    send_error(res, res.status, res.status == 404 ? "not found: this server has / and /api/{info,render,camera,save}"
                                                  : "bad request");
  });
  http_->set_exception_handler([](const httplib::Request& req, httplib::Response& res, std::exception_ptr) {
    send_error(res, 500, "internal error");
  });
  http_->set_logger([](const httplib::Request& req, const httplib::Response& res) {
    spdlog::debug("{} {} -> {}", req.method, req.path, res.status);
  });

  http_->Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Content-Security-Policy",
                   "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                   "img-src blob:; connect-src 'self'");
    res.set_content(view_page_html(), "text/html; charset=utf-8");
  });
  http_->Get("/api/info", [this](const httplib::Request&, httplib::Response& res) {
    json info = scene_.info();
    info["save_poses"] = config_.save_poses;
    send_json(res, info);
  });
  const OrbitView& view = scene_.default_view();
  http_->Post("/api/render", post_handler(view, [this](const ViewRequest& request, httplib::Response& res) {
    const ViewFrame frame = scene_.render(request);
    char ms[32];
    std::snprintf(ms, sizeof(ms), "%.2f", frame.frame_ms);
    res.set_header("X-Frame-Ms", ms);
    res.set_header("X-Gaussians", std::to_string(frame.gaussians));
    res.set_content(frame.bytes, frame.content_type.c_str());
  }));
  http_->Post("/api/camera", post_handler(view, [this](const ViewRequest& request, httplib::Response& res) {
    send_json(res, camera_to_json(scene_.camera_of(request)));
  }));
  http_->Post("/api/save", post_handler(view, [this](const ViewRequest& request, httplib::Response& res) {
    PoseFrame frame = scene_.pose_of(request);
    std::lock_guard<std::mutex> lock(save_mutex_);
    const size_t count = append_pose(config_.save_poses, frame);
    spdlog::info("saved pose {} to {}", count, config_.save_poses);
    send_json(res, {{"path", config_.save_poses}, {"count", count}});
  }));
}

int ViewServer::bind() {
  int port = config_.port;
  if (port == 0) {
    port = http_->bind_to_any_port(config_.host);
  } else if (!http_->bind_to_port(config_.host, port)) {
    port = -1;
  }
  require(port > 0, "--host " + config_.host + " --port " + std::to_string(config_.port) +
                        ": cannot listen there (the port is in use, or the host is not an address of "
                        "this machine)");
  return port;
}

void ViewServer::run() { http_->listen_after_bind(); }

bool ViewServer::running() const { return http_->is_running(); }

void ViewServer::stop() { http_->stop(); }

}  // namespace handscs
