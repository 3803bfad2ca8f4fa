// The talk output's pure parts: which words a `Talk(<phrase>)` says (a
// phrase table, `wakeup` -> "Good morning, Johanna. Time to wake up."), and
// how long a WAV file lasts (read from its RIFF header, every field checked),
// so the announcement can say when the speech ends.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace peis::devices {

class PhraseTable {
 public:
  PhraseTable();  // with the scenario's phrases (wakeup)
  // `KEY=TEXT`; throws std::invalid_argument.
  void add(const std::string& rule);
  // The words for a phrase: the table's text, or the phrase itself with
  // dashes as spaces (`good-night` -> "good night").
  std::string words(const std::string& phrase) const;

 private:
  std::map<std::string, std::string> phrases_;
};

// Seconds of audio in a PCM WAV file's bytes, or nothing (with the reason)
// when it is not one.
std::optional<double> wavSeconds(std::string_view bytes, std::string* problem = nullptr);

}  // namespace peis::devices
