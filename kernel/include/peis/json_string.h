// JSON string literals, written by hand: the one escaping every part of the
// platform uses for its JSON (the `peis` tool's --json, the meta-level's
// programs, the view's protocol, `peis inspect --json`). The output is
// always valid JSON and valid UTF-8 whatever the input bytes (a tuple's data
// is any bytes), since a browser closes a WebSocket whose text is not.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace peis::json {

// Appends `text` as a JSON string literal (RFC 8259): `"` and `\` escaped,
// newline, carriage return and tab as `\n`, `\r`, `\t`, every other control
// byte and DEL as `\u00XX`; valid UTF-8 as it is; each byte that starts no
// valid UTF-8 sequence (a stray continuation byte, an overlong form, a
// surrogate, beyond U+10FFFF, a sequence cut short) as U+FFFD.
void appendString(std::string& out, std::string_view text);
// The same, as a new string.
std::string quote(std::string_view text);

// The length (1 to 4) of the valid UTF-8 sequence that starts at text[at],
// or 0 when none does (no overlongs, no surrogates, nothing past U+10FFFF).
std::size_t utf8SequenceLength(std::string_view text, std::size_t at);
// True when all of `text` is valid UTF-8.
bool isValidUtf8(std::string_view text);

}  // namespace peis::json
