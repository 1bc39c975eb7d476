// The planning service `dsmplan view --serve URL` passes the page's requests to: the view server
// answers the page's /v1/plan, /v1/info and /v1/health by asking the one service named on its
// command line, so that the browser talks to one origin and the token never reaches the page.
#pragma once

#include <httplib.h>

#include <string>

namespace dsmplan {

class ServiceProxy {
public:
  /// `url`: http://HOST[:PORT][/] (ArgumentError("--serve") otherwise: no path, query, user or
  /// https); `token_file`: the service's bearer token (read_token(); "" for none).
  ServiceProxy(const std::string& url, const std::string& token_file);
  /// The page's request (POST /v1/plan, GET /v1/info or /v1/health: the caller routes only
  /// these) sent to the service with the token; its status and JSON passed back, or 502 with
  /// {"error": one line} when the service does not answer.
  void forward(const httplib::Request& request, httplib::Response& response) const;
  const std::string& url() const { return url_; }

private:
  std::string url_, host_, token_, token_file_;
  int port_ = 80;
};

}  // namespace dsmplan
