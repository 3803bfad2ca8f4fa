// peis-view's PEIS side and its pages (view_service.h).
#include "view/view_service.h"

#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "peis/conventions.h"
#include "peis/log.h"
#include "view/client_state.h"
#include "view/filter.h"
#include "view/graph.h"
#include "view/http_target.h"
#include "view/image_convert.h"
#include "view/json.h"
#include "view/messages.h"
#include "view/subscriptions.h"
#include "view/tuple_store.h"
#include "view/web_server.h"
#include "view_css.h"
#include "view_index_html.h"
#include "view_js.h"

namespace peis::view {
namespace {

using SteadyClock = std::chrono::steady_clock;

// What the kernel's callbacks and the writes' completions share with the
// service; kept alive by them, so one that runs late finds it still there.
struct Shared {
  std::mutex storeMu;
  TupleStore store;
  std::mutex serverMu;
  WebServer* server = nullptr;  // null once the service stops

  void post(std::function<void()> fn) {
    std::lock_guard lock(serverMu);
    if (server) server->post(std::move(fn));
  }
};

struct Page {
  std::weak_ptr<WebClient> client;
  ClientState state;
  std::optional<Filter> pendingFilter;  // applied at the next tick
  std::string filterSubscription;
  std::string plotSubscription;
  std::size_t pendingWrites = 0;
};

struct CachedPicture {
  std::uint64_t seqno = 0;
  SteadyClock::time_point made{};
  Picture picture;
};

HttpReply fileReply(const char* contentType, const char* body) {
  HttpReply reply;
  reply.contentType = contentType;
  reply.body = body;
  return reply;
}

HttpReply errorReply(int status, const std::string& text) {
  HttpReply reply;
  reply.status = status;
  reply.body = text + "\n";
  return reply;
}

std::string codeText(const Error& e) { return toString(e.code()); }

}  // namespace

struct ViewService::Impl {
  Kernel& kernel;
  ViewSettings settings;
  std::shared_ptr<Shared> shared = std::make_shared<Shared>();
  std::vector<Filter> metaFilters;
  Filter initialFilter;
  std::unique_ptr<WebServer> server;
  // The rest is used on the server thread only.
  std::unique_ptr<SubscriptionSet> subscriptions;
  std::map<std::uint64_t, Page> pages;
  std::uint64_t graphVersion = 0;
  std::shared_ptr<const std::string> graphJson;
  std::map<PeisId, std::uint64_t> allKeysSeen;  // seqno of kernel.all-keys followed
  std::map<PeisId, std::map<std::string, std::string>> metaSubscriptions;  // key -> subscription
  std::map<TupleRef, CachedPicture> pictures;
  SteadyClock::time_point lastSecond{};
  SteadyClock::time_point lastGraph{};
  std::uint64_t publishedClients = ~0ull, publishedDropped = ~0ull;
  std::vector<CallbackHandle> callbacks;

  Impl(Kernel& k, ViewSettings s) : kernel(k), settings(std::move(s)) {}

  PeisId resolve(std::string_view name) const { return kernel.resolveOwner(name); }
  OwnerResolver resolver() const {
    return [this](std::string_view name) { return resolve(name); };
  }

  // OWNER.KEY of a page's command, the owner an id or a name.
  TupleRef tupleOf(const std::string& text) const {
    const FullName name = parseFullName(text);
    const PeisId owner = name.ownerId() ? *name.ownerId() : resolve(name.owner);
    return TupleRef{owner, name.key};
  }

  void start();
  void tick();
  void followMetaInputs(const std::vector<PeerInfo>& peers, SteadyClock::time_point now);
  void rebuildGraph(const std::vector<PeerInfo>& peers);
  void publishCounters();
  void opened(const std::shared_ptr<WebClient>& client);
  void closed(const std::shared_ptr<WebClient>& client);
  void message(const std::shared_ptr<WebClient>& client, std::string text, bool binary);
  void onGet(WebClient& client, const GetCommand& get);
  void onSet(const std::shared_ptr<WebClient>& client, Page& page, const SetCommand& set);
  HttpReply httpGet(const std::string& path, const std::string& query);
  HttpReply picture(const std::string& query);
  HttpReply statsReply();
};

ViewService::ViewService(Kernel& kernel, ViewSettings settings)
    : impl_(std::make_unique<Impl>(kernel, std::move(settings))) {
  auto& s = impl_->settings;
  // Names in these filters resolve only once their PEIS are known: at start
  // only ids and `*` make sense, so names are refused with that reason.
  const OwnerResolver noNames = [](std::string_view name) -> PeisId {
    throw Error(ErrorCode::NotFound, "'" + std::string(name) +
                                         "': give PEIS ids in start-up filters (names resolve on "
                                         "the page)");
  };
  try {
    impl_->initialFilter = parseFilter(s.filter, noNames);
  } catch (const FilterError& e) {
    throw std::invalid_argument("--filter: " + std::string(e.what()));
  }
  for (const auto& text : s.metaFilters) {
    try {
      impl_->metaFilters.push_back(parseFilter(text, noNames));
    } catch (const FilterError& e) {
      throw std::invalid_argument("--meta: " + std::string(e.what()));
    }
  }
  impl_->shared->store.setLogFilters(impl_->metaFilters);
  WebLimits limits;
  limits.maxQueueBytes = s.maxQueueBytes;
  limits.stallTimeout = s.stallTimeout;
  // An edit's value arrives JSON-escaped (up to 6 bytes a byte) in one message.
  limits.maxMessageBytes = s.maxEditBytes * 6 + 64 * 1024;
  WebHandlers handlers;
  Impl* impl = impl_.get();
  handlers.get = [impl](const std::string& path, const std::string& query) {
    return impl->httpGet(path, query);
  };
  handlers.opened = [impl](const std::shared_ptr<WebClient>& c) { impl->opened(c); };
  handlers.closed = [impl](const std::shared_ptr<WebClient>& c, const std::string&) {
    impl->closed(c);
  };
  handlers.message = [impl](const std::shared_ptr<WebClient>& c, std::string text, bool binary) {
    impl->message(c, std::move(text), binary);
  };
  impl_->server = std::make_unique<WebServer>(s.address, s.port, limits, std::move(handlers));
  impl_->shared->server = impl_->server.get();
}

ViewService::~ViewService() {
  {
    std::lock_guard lock(impl_->shared->serverMu);
    impl_->shared->server = nullptr;
  }
  for (auto handle : impl_->callbacks) impl_->kernel.removeCallback(handle);
  // Stops the server thread; then nothing else uses the pages or the subscriptions.
  impl_->server.reset();
  impl_->pages.clear();
  impl_->subscriptions.reset();
}

std::uint16_t ViewService::port() const { return impl_->server->port(); }

std::string ViewService::url() const {
  const std::string host = impl_->settings.address.find(':') != std::string::npos
                               ? "[" + impl_->settings.address + "]"
                               : impl_->settings.address;
  return "http://" + host + ":" + std::to_string(port()) + "/";
}

void ViewService::start() { impl_->start(); }

void ViewService::Impl::start() {
  std::weak_ptr<Shared> weak = shared;
  callbacks.push_back(kernel.onChange(Pattern(), [weak](const Tuple& tuple) {
    if (auto s = weak.lock()) {
      std::lock_guard lock(s->storeMu);
      s->store.change(tuple, systemNow());
    }
  }));
  callbacks.push_back(kernel.onDelete(Pattern(), [weak](const Tuple& tuple) {
    if (auto s = weak.lock()) {
      std::lock_guard lock(s->storeMu);
      s->store.remove(tuple, systemNow());
    }
  }));
  {
    // What the kernel holds already (its own kernel.* tuples).
    const auto held = kernel.find(Pattern());
    std::lock_guard lock(shared->storeMu);
    for (const auto& tuple : held) shared->store.change(tuple, systemNow());
  }
  subscriptions = std::make_unique<SubscriptionSet>(
      [this](const Pattern& p) { return kernel.subscribe(p); },
      [this](std::uint64_t handle) { kernel.unsubscribe(handle); });
  const auto now = SteadyClock::now();
  // What the graph, the components and the configuration are drawn from.
  for (const char* key : {"kernel.name", "kernel.hostname", "kernel.links", "kernel.all-keys",
                          "status", "cause.names", "component.name"}) {
    subscriptions->acquire(Pattern(key), now);
  }
  for (const auto& filter : metaFilters) subscriptions->acquire(filter.pattern, now);
  const auto period =
      std::chrono::milliseconds(std::max<long>(1, static_cast<long>(1000.0 / settings.updateRate)));
  kernel.set("view.url", "http://127.0.0.1:" + std::to_string(server->port()) + "/");
  publishCounters();  // from here on only on the server thread
  server->every(period, [this] { tick(); });
  server->start();
}

void ViewService::Impl::publishCounters() {
  const auto& stats = server->stats();
  const std::uint64_t open = stats.clientsOpen, dropped = stats.clientsDropped;
  if (open != publishedClients) kernel.set("view.clients", std::to_string(open));
  if (dropped != publishedDropped) kernel.set("view.clients.dropped", std::to_string(dropped));
  publishedClients = open;
  publishedDropped = dropped;
}

void ViewService::Impl::followMetaInputs(const std::vector<PeerInfo>& peers,
                                         SteadyClock::time_point now) {
  std::set<PeisId> reachable;
  for (const auto& peer : peers) {
    reachable.insert(peer.id);
    std::uint64_t seqno = 0;
    {
      std::lock_guard lock(shared->storeMu);
      const StoredTuple* keys = shared->store.find(peer.id, "kernel.all-keys");
      if (!keys || keys->deleted) continue;
      seqno = keys->seqno;
    }
    auto seen = allKeysSeen.find(peer.id);
    if (seen != allKeysSeen.end() && seen->second == seqno) continue;
    allKeysSeen[peer.id] = seqno;
    const auto all = kernel.get(peer.id, "kernel.all-keys");
    if (!all) continue;
    std::set<std::string> wanted;
    std::istringstream keys(all->data);
    for (std::string key; keys >> key;) {
      if (isMetaInputKey(key)) wanted.insert(key);
    }
    auto& held = metaSubscriptions[peer.id];
    for (auto it = held.begin(); it != held.end();) {
      if (wanted.count(it->first)) {
        ++it;
        continue;
      }
      subscriptions->release(it->second, now);
      it = held.erase(it);
    }
    for (const auto& key : wanted) {
      if (held.count(key)) continue;
      try {
        held[key] = subscriptions->acquire(Pattern::exact(peer.id, key), now);
      } catch (const Error&) {
        // not a valid key: nothing to follow
      }
    }
  }
  for (auto it = metaSubscriptions.begin(); it != metaSubscriptions.end();) {
    if (reachable.count(it->first)) {
      ++it;
      continue;
    }
    for (const auto& [key, subscription] : it->second) subscriptions->release(subscription, now);
    allKeysSeen.erase(it->first);
    it = metaSubscriptions.erase(it);
  }
}

void ViewService::Impl::rebuildGraph(const std::vector<PeerInfo>& peers) {
  std::string json;
  {
    std::lock_guard lock(shared->storeMu);
    const Graph graph = buildGraph(peers, kernel.id(), shared->store);
    json = encodeGraph(graph, kernel.id());
  }
  if (!graphJson || *graphJson != json) {
    graphJson = std::make_shared<const std::string>(std::move(json));
    ++graphVersion;
  }
}

void ViewService::Impl::tick() {
  const auto steadyNow = SteadyClock::now();
  const Timestamp now = systemNow();
  // The graph and the meta tuples to follow, at most five times a second
  // whatever --rate is: reading the routing table takes the kernel's lock.
  if (steadyNow - lastGraph >= std::chrono::milliseconds(200)) {
    lastGraph = steadyNow;
    const auto peers = kernel.peers();
    followMetaInputs(peers, steadyNow);
    rebuildGraph(peers);
  }
  for (auto& [id, page] : pages) {
    auto client = page.client.lock();
    if (!client || client->closed() || !client->idle()) continue;
    if (page.pendingFilter) {
      const std::string previous = page.filterSubscription;
      page.filterSubscription = subscriptions->acquire(page.pendingFilter->pattern, steadyNow);
      subscriptions->release(previous, steadyNow);
      page.state.setFilter(std::move(*page.pendingFilter));
      page.pendingFilter.reset();
    }
    Update update;
    {
      std::lock_guard lock(shared->storeMu);
      update = page.state.collect(shared->store, graphVersion, graphJson, now);
    }
    if (!update.empty()) client->send(encodeUpdate(update));
  }
  if (steadyNow - lastSecond >= std::chrono::seconds(1)) {
    lastSecond = steadyNow;
    subscriptions->expire(steadyNow);
    {
      std::lock_guard lock(shared->storeMu);
      shared->store.purgeTombstones(now);
    }
    publishCounters();
  }
}

void ViewService::Impl::opened(const std::shared_ptr<WebClient>& client) {
  Page page{client, ClientState(initialFilter), std::nullopt, "", "", 0};
  page.filterSubscription = subscriptions->acquire(initialFilter.pattern, SteadyClock::now());
  pages.emplace(client->id(), std::move(page));
  HelloInfo hello;
  hello.self = kernel.id();
  hello.name = kernel.name();
  hello.ecology = kernel.options().ecology;
  hello.updateRate = settings.updateRate;
  hello.imageRate = settings.imageRate;
  hello.maxEditBytes = settings.maxEditBytes;
  hello.maxMessageBytes = settings.maxEditBytes * 6 + 64 * 1024;
  hello.filter = initialFilter.text;
  for (const auto& f : metaFilters) hello.metaFilters.push_back(f.text);
  client->send(encodeHello(hello));
}

void ViewService::Impl::closed(const std::shared_ptr<WebClient>& client) {
  auto it = pages.find(client->id());
  if (it == pages.end()) return;
  const auto now = SteadyClock::now();
  subscriptions->release(it->second.filterSubscription, now);
  if (!it->second.plotSubscription.empty())
    subscriptions->release(it->second.plotSubscription, now);
  pages.erase(it);
}

void ViewService::Impl::message(const std::shared_ptr<WebClient>& client, std::string text,
                                bool binary) {
  auto it = pages.find(client->id());
  if (it == pages.end()) return;
  Page& page = it->second;
  if (binary) {
    client->send(encodeError(
        CommandError{"binary messages are not understood: send JSON text", "", std::nullopt}));
    return;
  }
  auto decoded = decodeCommand(text, settings.maxEditBytes);
  if (auto* error = std::get_if<CommandError>(&decoded)) {
    client->send(encodeError(*error));
    return;
  }
  const Command& command = std::get<Command>(decoded);
  try {
    if (const auto* filter = std::get_if<FilterCommand>(&command)) {
      page.pendingFilter = parseFilter(filter->pattern, resolver());
    } else if (const auto* plot = std::get_if<PlotCommand>(&command)) {
      std::optional<TupleRef> ref;
      if (plot->tuple) ref = tupleOf(*plot->tuple);
      const auto now = SteadyClock::now();
      if (!page.plotSubscription.empty()) subscriptions->release(page.plotSubscription, now);
      page.plotSubscription.clear();
      if (ref)
        page.plotSubscription = subscriptions->acquire(Pattern::exact(ref->owner, ref->key), now);
      page.state.setPlot(ref);
    } else if (const auto* get = std::get_if<GetCommand>(&command)) {
      onGet(*client, *get);
    } else if (const auto* set = std::get_if<SetCommand>(&command)) {
      onSet(client, page, *set);
    }
  } catch (const FilterError& e) {
    client->send(encodeError(CommandError{e.what(), "filter", std::nullopt}));
  } catch (const Error& e) {
    const char* op = std::holds_alternative<PlotCommand>(command) ? "plot" : "filter";
    client->send(encodeError(CommandError{e.what(), op, std::nullopt}));
  }
}

void ViewService::Impl::onGet(WebClient& client, const GetCommand& get) {
  TupleRef ref;
  try {
    ref = tupleOf(get.tuple);
  } catch (const Error& e) {
    client.send(encodeReplyError(get.request, "get", get.tuple, e.what(), codeText(e)));
    return;
  }
  const auto tuple = kernel.get(ref.owner, ref.key);
  if (!tuple) {
    client.send(encodeReplyError(get.request, "get", get.tuple,
                                 "the view holds no value of " + ref.str(), "not found"));
    return;
  }
  if (tuple->data.size() > settings.maxEditBytes) {
    client.send(encodeReplyError(get.request, "get", get.tuple,
                                 ref.str() + " holds " + std::to_string(tuple->data.size()) +
                                     " bytes, over this view's edit limit of " +
                                     std::to_string(settings.maxEditBytes) +
                                     " bytes (peis view --max-edit)",
                                 "too large"));
    return;
  }
  const Preview kind = makePreview(tuple->data, tuple->encoding, tuple->data.size());
  if (kind.binary) {
    client.send(encodeReplyError(get.request, "get", get.tuple,
                                 ref.str() + " holds binary data (" +
                                     std::to_string(tuple->data.size()) + " bytes, " +
                                     tuple->mimetype + "), not text to edit",
                                 "binary"));
    return;
  }
  client.send(encodeGetReply(get.request, ref.str(), tuple->data, tuple->mimetype, tuple->seqno));
}

void ViewService::Impl::onSet(const std::shared_ptr<WebClient>& client, Page& page,
                              const SetCommand& set) {
  auto fail = [&](const std::string& error, const std::string& code) {
    client->send(encodeReplyError(set.request, "set", set.tuple, error, code));
  };
  if (page.pendingWrites >= settings.maxPendingWrites) {
    fail(std::to_string(page.pendingWrites) +
             " edits of this page still wait for their owners' answers: wait for them",
         "busy");
    return;
  }
  TupleRef ref;
  try {
    ref = tupleOf(set.tuple);
  } catch (const Error& e) {
    fail(e.what(), codeText(e));
    return;
  }
  WriteOptions options;
  if (set.mimetype) options.mimetype = *set.mimetype;
  const std::uint64_t clientId = client->id();
  const std::uint64_t request = set.request;
  const std::string name = ref.str();
  std::weak_ptr<Shared> weak = shared;
  ++page.pendingWrites;
  // The answer comes on the kernel thread; it goes to the page from the server's.
  auto done = [weak, this, clientId, request, name](const std::optional<Error>& error,
                                                    std::uint64_t seqno) {
    auto s = weak.lock();
    if (!s) return;
    std::string reply =
        error ? encodeReplyError(request, "set", name, error->what(), codeText(*error))
              : encodeSetReply(request, name, seqno);
    s->post([this, clientId, reply = std::move(reply)]() mutable {
      auto it = pages.find(clientId);
      if (it == pages.end()) return;
      if (it->second.pendingWrites > 0) --it->second.pendingWrites;
      if (auto c = it->second.client.lock()) c->send(std::move(reply));
    });
  };
  try {
    kernel.setAsync(ref.owner, ref.key, set.value, options, done);
  } catch (const Error& e) {
    --page.pendingWrites;
    fail(e.what(), codeText(e));
  }
}

HttpReply ViewService::Impl::httpGet(const std::string& path, const std::string& query) {
  if (path == "/" || path == "/index.html")
    return fileReply("text/html; charset=utf-8", kIndexHtml);
  if (path == "/view.js") return fileReply("text/javascript; charset=utf-8", kViewJs);
  if (path == "/view.css") return fileReply("text/css; charset=utf-8", kViewCss);
  if (path == "/image") return picture(query);
  if (path == "/stats") return statsReply();
  return errorReply(404, "not found: " + path +
                             " (the view serves /, /image?tuple=OWNER.KEY, "
                             "/stats and the WebSocket /ws)");
}

HttpReply ViewService::Impl::picture(const std::string& query) {
  const auto text = queryParameter(query, "tuple");
  if (!text || text->empty()) return errorReply(400, "give the tuple: /image?tuple=OWNER.KEY");
  TupleRef ref;
  try {
    ref = tupleOf(*text);
  } catch (const Error& e) {
    return errorReply(400, e.what());
  }
  // The picture made last is served again while it is the latest, or was
  // made less than 1/--image-rate ago: then the data is not even copied.
  std::optional<std::uint64_t> seqno;
  {
    std::lock_guard lock(shared->storeMu);
    const StoredTuple* stored = shared->store.find(ref.owner, ref.key);
    if (stored && !stored->deleted) seqno = stored->seqno;
  }
  const auto now = SteadyClock::now();
  const auto minInterval = std::chrono::duration<double>(1.0 / settings.imageRate);
  auto cached = pictures.find(ref);
  const bool fresh = seqno && cached != pictures.end() &&
                     (cached->second.seqno == *seqno || now - cached->second.made < minInterval);
  if (!fresh) {
    const auto tuple = kernel.get(ref.owner, ref.key);
    if (!tuple) return errorReply(404, "the view holds no value of " + ref.str());
    std::string why;
    auto converted = toPicture(tuple->mimetype, tuple->data, why);
    if (!converted) return errorReply(415, ref.str() + ": " + why);
    if (pictures.size() >= 64 && cached == pictures.end()) pictures.erase(pictures.begin());
    pictures[ref] = CachedPicture{tuple->seqno, now, std::move(*converted)};
    cached = pictures.find(ref);
  }
  HttpReply reply;
  reply.contentType = cached->second.picture.mimetype;
  reply.body = cached->second.picture.data;
  reply.headers.emplace_back("X-Peis-Seqno", std::to_string(cached->second.seqno));
  return reply;
}

HttpReply ViewService::Impl::statsReply() {
  const auto& stats = server->stats();
  json::Writer w;
  w.beginObject();
  w.key("self").integer(kernel.id());
  w.key("clientsOpen").unsignedInteger(stats.clientsOpen);
  w.key("clientsAccepted").unsignedInteger(stats.clientsAccepted);
  w.key("clientsDropped").unsignedInteger(stats.clientsDropped);
  w.key("clientsDroppedQueue").unsignedInteger(stats.clientsDroppedQueue);
  w.key("clientsDroppedStalled").unsignedInteger(stats.clientsDroppedStalled);
  w.key("messagesSent").unsignedInteger(stats.messagesSent);
  w.key("bytesSent").unsignedInteger(stats.bytesSent);
  w.key("httpRequests").unsignedInteger(stats.httpRequests);
  w.key("refusedRequests").unsignedInteger(stats.refusedRequests);
  w.key("subscriptions").unsignedInteger(subscriptions ? subscriptions->active() : 0);
  {
    std::lock_guard lock(shared->storeMu);
    w.key("tuples").unsignedInteger(shared->store.size());
    w.key("version").unsignedInteger(shared->store.version());
  }
  w.endObject();
  HttpReply reply;
  reply.contentType = "application/json";
  reply.body = w.take();
  return reply;
}

}  // namespace peis::view
