// peis-view (`peis view`): the ecology in the browser. A PEIS that serves
// a page on this machine showing the ecology as a graph, a live table of
// tuples, plots, pictures, the meta-level's configuration and events, and
// edits tuples through remote writes. docs/operating.md, docs/cli.md.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>

#include "common/command_line.h"
#include "peis/kernel.h"
#include "peis/log.h"
#include "view/view_service.h"

extern char** environ;

namespace {

const char* kUsage = R"usage(Usage: peis view [OPTIONS] [--peis-* options]
       (the program peis-view; `peis view` runs it)

Serves the ecology in the browser, on this machine only, and prints the
page's URL: the PEIS and their links as a graph with the configuration's
meta-tuple links (consumer <- producer), a live table of the tuples that
match a filter (owner, key, value, seqno, age, rate), a plot of a numeric
tuple, image tuples as pictures, edits (remote writes to the owner), the
meta-level's configuration and events, and components' status. Runs until
SIGINT, SIGTERM or kernel.do-quit = yes.

Options:
  --port N            TCP port on 127.0.0.1 (default 7780; 0: any free port)
  --open              also open the page in the desktop's browser (xdg-open)
  --rate N            updates per second to each page, at most; each tuple
                      comes at most once per update, with its latest value
                      (default 10; 0.1..100)
  --image-rate N      pictures per second of one image tuple, at most
                      (default 2; 0.1..50)
  --filter PATTERN    the table's filter when a page opens (default *.**):
                      OWNER.KEYPATTERN [creator=ID] [mimetype=TYPE]
  --meta PATTERN      the meta-level's tuples: its panel and event log
                      (repeatable; default *.config.** and *.events.**)
  --max-queue BYTES   a page whose send queue would pass this is dropped
                      (default 8388608)
  --stall-timeout S   a page that takes no message for S seconds is dropped
                      (default 10; 0.1..3600)
  --max-edit BYTES    the largest value a page may write (default 1048576)
  --verbose, -v       the kernel's info log lines on stderr
  --help, -h          this text
)usage";

// Opens `url` with xdg-open, without waiting for it.
void openInBrowser(const std::string& url) {
  const char* argv[] = {"xdg-open", url.c_str(), nullptr};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int error =
      posix_spawnp(&pid, "xdg-open", &actions, nullptr, const_cast<char* const*>(argv), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (error != 0) {
    std::cerr << "peis view: cannot open a browser (xdg-open: " << std::strerror(error)
              << "); open " << url << " yourself\n";
    return;
  }
  std::thread([pid] { waitpid(pid, nullptr, 0); }).detach();  // reaped when it ends
}

}  // namespace

int main(int argc, char** argv) {
  using peis::components::badArgument;
  using peis::components::parseNumber;
  const std::string program = "peis view";
  peis::Options options;
  if (auto done =
          peis::components::parsePeisOptions(argc, argv, program, kUsage, "peis-view", options))
    return *done;
  peis::view::ViewSettings settings;
  bool open = false, verbose = false, metaGiven = false;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string value;
    bool inlineValue = false;
    if (arg.rfind("--", 0) == 0 && arg.find('=') != std::string::npos) {
      value = arg.substr(arg.find('=') + 1);
      arg = arg.substr(0, arg.find('='));
      inlineValue = true;
    }
    auto takesValue = [&]() -> bool {
      if (inlineValue) return true;
      if (i + 1 >= argc) return false;
      value = argv[++i];
      return true;
    };
    double number = 0;
    if (arg == "--open") {
      open = true;
    } else if (arg == "--verbose" || arg == "-v") {
      verbose = true;
    } else if (arg == "--port") {
      if (!takesValue() || !parseNumber(value.c_str(), 0, 65535, &number) ||
          number != static_cast<int>(number))
        return badArgument(program, arg, "a port number 0..65535");
      settings.port = static_cast<std::uint16_t>(number);
    } else if (arg == "--rate") {
      if (!takesValue() || !parseNumber(value.c_str(), 0.1, 100, &number))
        return badArgument(program, arg, "updates per second, 0.1..100");
      settings.updateRate = number;
    } else if (arg == "--image-rate") {
      if (!takesValue() || !parseNumber(value.c_str(), 0.1, 50, &number))
        return badArgument(program, arg, "pictures per second, 0.1..50");
      settings.imageRate = number;
    } else if (arg == "--filter") {
      if (!takesValue()) return badArgument(program, arg, "needs a pattern");
      settings.filter = value;
    } else if (arg == "--meta") {
      if (!takesValue()) return badArgument(program, arg, "needs a pattern");
      if (!metaGiven) settings.metaFilters.clear();
      metaGiven = true;
      settings.metaFilters.push_back(value);
    } else if (arg == "--max-queue") {
      if (!takesValue() || !parseNumber(value.c_str(), 65536, 1e10, &number))
        return badArgument(program, arg, "bytes, 65536..10000000000");
      settings.maxQueueBytes = static_cast<std::size_t>(number);
    } else if (arg == "--stall-timeout") {
      if (!takesValue() || !parseNumber(value.c_str(), 0.1, 3600, &number))
        return badArgument(program, arg, "seconds, 0.1..3600");
      settings.stallTimeout = std::chrono::milliseconds(static_cast<long>(number * 1000));
    } else if (arg == "--max-edit") {
      if (!takesValue() || !parseNumber(value.c_str(), 1, 64.0 * 1024 * 1024, &number))
        return badArgument(program, arg, "bytes, 1..67108864");
      settings.maxEditBytes = static_cast<std::size_t>(number);
    } else {
      return badArgument(
          program, arg,
          peis::components::unknownArgument(arg, i + 1 < argc ? argv[i + 1] : nullptr));
    }
  }
  // Like the `peis` commands, the view prints its URL, not the kernel's log.
  if (verbose)
    peis::log::setLevel(peis::log::Level::Info);
  else if (!peis::log::levelFromEnvironment())
    peis::log::setLevel(peis::log::Level::Warn);
  // An observer, as the `peis` commands are: it takes no part in the overlay
  // and the others' membership, so opening a view never re-shapes the ecology.
  options.tool = true;
  try {
    peis::Kernel kernel(options);
    std::unique_ptr<peis::view::ViewService> view;
    try {
      view = std::make_unique<peis::view::ViewService>(kernel, settings);
    } catch (const std::invalid_argument& e) {
      std::cerr << program << ": " << e.what() << " (see --help)\n";
      return 2;
    } catch (const std::runtime_error& e) {
      std::cerr << program << ": " << e.what()
                << (settings.port != 0 ? " (--port N picks another port, 0 any free one)" : "")
                << "\n";
      return 2;
    }
    view->start();
    std::cout << "peis view: " << view->url() << std::endl;
    if (open) openInBrowser(view->url());
    const std::string reason = kernel.run();
    std::cerr << "peis view: " << reason << "\n";
    view.reset();
  } catch (const peis::Error& e) {
    std::cerr << program << ": " << e.what() << "\n";
    return 2;
  }
  return 0;
}
