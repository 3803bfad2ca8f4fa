// The pure parts of the view's HTTP handling: a request target's query
// parameters (percent-decoded), and whether a Host or Origin header names
// this machine (the server answers nothing else: web_server.h).
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace peis::view {

// "%41b+c" -> "Ab c"; nothing for a malformed escape.
std::optional<std::string> percentDecode(std::string_view text);
// The value of parameter `name` in a query ("tuple=12.image&x=1"),
// percent-decoded; nothing when absent or malformed.
std::optional<std::string> queryParameter(std::string_view query, std::string_view name);

// True when a Host header names this machine: localhost, 127.0.0.1 or
// [::1], with or without a port.
bool isLocalHost(std::string_view host);
// True for the Origin of a page of this machine (http://localhost:PORT,
// http://127.0.0.1:PORT, http://[::1]:PORT) and for none at all (a client
// that is not a browser sends none).
bool isLocalOrigin(std::string_view origin);

}  // namespace peis::view
