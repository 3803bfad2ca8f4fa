// peis-talk: the talk output of a robot. `Talk(<phrase>)` written to its
// ExecGoal is spoken with espeak-ng into a WAV file (no sound card needed),
// announced as the `speech` tuple, and passed to the robot's driver as
// TalkCommand (in the simulated home the world then wakes whoever hears it).
// docs/components/talk.md.
#include <peis/component.h>
#include <spawn.h>
#include <sys/wait.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include "execution/exec_server.h"
#include "execution/program_options.h"
#include "speech.h"
#include "talk_descriptor.h"

extern char** environ;

namespace {

const char* kUsage = R"usage(Usage: peis-talk [OPTIONS] [--peis-* flags]

Says phrases: an ExecGoal Talk(wakeup) becomes speech in a WAV file (espeak-ng),
the tuple speech = "FILE SECONDS WORDS", and TalkCommand = WORDS on the driver.

Options:
  --base NAME        the robot's driver PEIS for TalkCommand (default: none)
  --out-dir DIR      where the WAV files go (default: the current directory)
  --voice VOICE      espeak-ng voice (default: en)
  --phrase KEY=TEXT  what Talk(KEY) says; repeatable (wakeup is built in)
  --espeak PATH      the espeak-ng program (default: espeak-ng on PATH)
  --help             this text
)usage";

// Runs espeak-ng; returns its exit status or -1 if it could not start.
int speak(const std::string& program, const std::string& voice, const std::string& file,
          const std::string& words) {
  std::vector<std::string> args{program, "-v", voice, "-w", file, "--", words};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

}  // namespace

int main(int argc, char** argv) {
  if (peis::exec::printedHelp(argc, argv, kUsage)) return 0;
  peis::Kernel kernel(argc, argv);
  std::string base, outDir = ".", voice = "en", espeak = "espeak-ng";
  peis::devices::PhraseTable phrases;
  const int code = peis::exec::parseProgramOptions(
      argc, argv, "peis-talk", kUsage, [&](const std::string& name, const std::string& value) {
        if (name == "--base")
          base = value;
        else if (name == "--out-dir")
          outDir = value;
        else if (name == "--voice")
          voice = value;
        else if (name == "--espeak")
          espeak = value;
        else if (name == "--phrase")
          phrases.add(value);  // throws on a bad rule
        else
          return false;
        return true;
      });
  if (code >= 0) return code;
  std::error_code ec;
  std::filesystem::create_directories(outDir, ec);
  if (!std::filesystem::is_directory(outDir)) {
    std::cerr << "peis-talk: cannot use --out-dir " << outDir << "\n";
    return 1;
  }
  peis::Component component(kernel, "talk",
                            peis::Descriptor::fromYaml(kTalkDescriptor, "talk.yaml"));
  std::unique_ptr<peis::exec::ExecServer> server;
  std::vector<std::thread> workers;  // one per utterance; joined at exit
  std::uint64_t count = 0;
  server = std::make_unique<peis::exec::ExecServer>(
      kernel,
      [](const peis::exec::Action& a) -> std::optional<std::string> {
        if (a.name != "Talk" || a.args.size() != 1) return "talk does Talk(<phrase>)";
        return std::nullopt;
      },
      [&](const peis::exec::Action& a, std::uint64_t id) {
        const std::string words = phrases.words(a.args[0]);
        const std::string file =
            (std::filesystem::path(outDir) / ("talk-" + std::to_string(++count) + ".wav")).string();
        server->publish({peis::exec::ExecState::Running, id, a.toString(), ""});
        std::cerr << "talk: saying \"" << words << "\"" << std::endl;
        // espeak-ng runs off the kernel thread; the result is posted back.
        workers.emplace_back([&, id, action = a.toString(), words, file] {
          const int code = speak(espeak, voice, file, words);
          std::ifstream in(file, std::ios::binary);
          std::stringstream bytes;
          bytes << in.rdbuf();
          std::string problem;
          const auto seconds =
              code == 0 ? peis::devices::wavSeconds(bytes.str(), &problem) : std::nullopt;
          // The driver may not be known yet (it joined after this PEIS
          // started): wait for it here, off the kernel thread, a while.
          std::optional<peis::PeisId> driver;
          if (!base.empty()) driver = kernel.waitForPeer(base, std::chrono::seconds(10));
          kernel.post([&, id, action, words, file, code, seconds, problem, driver] {
            if (code != 0) {
              server->publish({peis::exec::ExecState::Failed, id, action,
                               code < 0 ? "cannot run " + espeak
                                        : espeak + " exited with " + std::to_string(code)});
              return;
            }
            if (!seconds) {
              server->publish(
                  {peis::exec::ExecState::Failed, id, action, "bad WAV " + file + ": " + problem});
              return;
            }
            char text[64];
            std::snprintf(text, sizeof text, " %.2f ", *seconds);
            kernel.set("speech", std::filesystem::absolute(file).string() + text + words);
            if (!base.empty()) {
              if (!driver) {
                std::cerr << "talk: no driver PEIS named " << base << " within 10 s" << std::endl;
                server->publish(
                    {peis::exec::ExecState::Failed, id, action, "no driver PEIS named " + base});
                return;
              }
              kernel.setAsync(*driver, "TalkCommand", words);
            }
            server->publish({peis::exec::ExecState::Success, id, action, ""});
          });
        });
      });
  component.start();
  kernel.run();
  for (auto& w : workers) w.join();
  server.reset();
  return 0;
}
