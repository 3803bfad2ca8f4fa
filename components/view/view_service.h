// peis-view's PEIS side: the kernel's callbacks feed the store (the only
// work done on the kernel thread, under one short lock), and the web
// server's thread does everything else: every tick it gathers what changed
// for each page that has taken its previous messages, answers the pages'
// commands (filters, plots, edits as remote writes to the owners), serves
// the page and the pictures of image tuples, and keeps the view's
// subscriptions to what the pages look at. So neither a slow page nor many
// pages ever hold up the kernel: a page that does not keep up gets fewer,
// coalesced updates, and one that stops is dropped. docs/operating.md.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "peis/kernel.h"

namespace peis::view {

struct ViewSettings {
  std::string address = "127.0.0.1";
  std::uint16_t port = 7780;
  double updateRate = 10;  // ticks per second: updates per page, each tuple at most once per tick
  double imageRate = 2;    // conversions per second per image tuple, at most
  std::size_t maxQueueBytes = 8u << 20;
  std::chrono::milliseconds stallTimeout{10000};
  std::size_t maxEditBytes = 1u << 20;
  std::size_t maxPendingWrites = 16;  // per page
  std::string filter = "*.**";
  std::vector<std::string> metaFilters = {"*.config.**", "*.events.**"};
};

class ViewService {
 public:
  // Checks the settings' filters (std::invalid_argument saying which is
  // bad) and listens on the port (std::runtime_error when it cannot).
  ViewService(Kernel& kernel, ViewSettings settings);
  ~ViewService();
  ViewService(const ViewService&) = delete;
  ViewService& operator=(const ViewService&) = delete;

  std::uint16_t port() const;
  std::string url() const;
  // Subscribes, registers the callbacks and starts serving.
  void start();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace peis::view
