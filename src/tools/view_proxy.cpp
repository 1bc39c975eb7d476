// dsmplan view --serve: the view server as a fixed reverse proxy to one planning service. The
// page could have called the service itself if the service sent CORS headers, but then the
// token would have to be in the page, and a second origin would have to be trusted; instead the
// page asks its own server, which forwards three fixed routes to the one address it was given.
#include "view_proxy.hpp"

#include <algorithm>
#include <cctype>

#include "core/text.hpp"
#include "dsmplan/core.hpp"
#include "dsmplan/serve.hpp"
#include "http_server.hpp"

namespace dsmplan {

namespace {

// "http://HOST[:PORT][/]" into host and port; anything else (a path, a query, user info, https,
// which this build's client does not speak) is refused, so the address means one service.
void parse_service_url(const std::string& url, std::string& host, int& port) {
  const auto refuse = [&url](const std::string& why) {
    throw ArgumentError("--serve", "'" + url + "' is not the planning service's address: " + why +
                                       " (e.g. http://127.0.0.1:8080, as dsmplan serve prints it)");
  };
  const std::string scheme = "http://";
  if (lower_case(url.substr(0, scheme.size())) != scheme) refuse("it must start with http://");
  std::string rest = url.substr(scheme.size());
  if (!rest.empty() && rest.back() == '/') rest.pop_back();
  if (rest.empty()) refuse("no host");
  if (rest.find_first_of("/?#@ \\") != std::string::npos) refuse("only http://HOST[:PORT], no path, query or user");
  const size_t close = rest.find(']');
  const size_t colon = rest.rfind(':');
  host = rest;
  port = 80;
  if (colon != std::string::npos && (close == std::string::npos || colon > close)) {
    host = rest.substr(0, colon);
    const std::string digits = rest.substr(colon + 1);
    if (digits.empty() || digits.size() > 5 ||
        !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
      refuse("the port is not a number");
    port = std::stoi(digits);
    if (port < 1 || port > 65535) refuse("the port must lie in [1, 65535]");
  }
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host.empty()) refuse("no host");
}

void answer(httplib::Response& response, int status, const std::string& body) {
  response.status = status;
  response.set_header("Cache-Control", "no-store");
  response.set_content(body, "application/json");
}

}  // namespace

ServiceProxy::ServiceProxy(const std::string& url, const std::string& token_file)
    : url_(url), token_(read_token(token_file)), token_file_(token_file) {
  parse_service_url(url, host_, port_);
  if (!url_.empty() && url_.back() == '/') url_.pop_back();
}

void ServiceProxy::forward(const httplib::Request& request, httplib::Response& response) const {
  httplib::Client client(host_, port_);
  client.set_connection_timeout(5, 0);
  // The service answers within its own --budget (at most an hour) or says 504; this only stops
  // a service that hangs from holding the page's request for ever.
  client.set_read_timeout(3600, 0);
  httplib::Headers headers;
  if (!token_.empty()) headers.emplace("Authorization", "Bearer " + token_);
  const httplib::Result result = request.method == "POST"
                                     ? client.Post(request.path.c_str(), headers, request.body, "application/json")
                                     : client.Get(request.path.c_str(), headers);
  if (!result)
    return answer(response, 502,
                  error_body("the planning service at " + url_ + " does not answer (" +
                             httplib::to_string(result.error()) + "): is dsmplan serve running there?"));
  if (result->status == 401)  // the service's own words name its header; the viewer's user needs the flag
    return answer(response, 502,
                  error_body("the planning service at " + url_ +
                             (token_.empty() ? " requires a token: give dsmplan view --serve-token-file"
                                             : " refused the token of " + token_file_)));
  answer(response, result->status, result->body);
}

}  // namespace dsmplan
