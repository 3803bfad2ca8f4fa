// The timeline a person follows while a scenario runs: one line per event,
// scenario time in simulated seconds (negative while the PEIS start), the
// PEIS, what happened in words, and the tuple:
//
//      12.4 s  plant          too much sun: asks the blind to close   plant.TiltValue = 0
//
// Formatting is pure; Timeline prints (thread-safe) and hands each line to
// a sink (the trace).
#pragma once

#include <peis/tuple.h>

#include <cstdio>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

namespace peis::scenario {

// A tuple's value for people: text shortened to `width` characters on one
// line, binary data as `<N bytes image/png>`, nothing for a deletion.
std::string formatValue(const Tuple& tuple, std::size_t width = 60);

std::string formatLine(std::optional<double> seconds, const std::string& peis,
                       const std::string& words, const std::string& tuple);

class Timeline {
 public:
  using Sink = std::function<void(std::optional<double> seconds, const std::string& peis,
                                  const std::string& words, const std::string& tuple)>;
  explicit Timeline(std::FILE* out = stdout) : out_(out) {}
  void setSink(Sink sink);
  void say(std::optional<double> seconds, const std::string& peis, const std::string& words,
           const std::string& tuple = "");

 private:
  std::mutex mu_;
  std::FILE* out_;
  Sink sink_;
};

}  // namespace peis::scenario
