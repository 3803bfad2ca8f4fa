// Building the view's graph of the ecology (graph.h).
#include "view/graph.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "peis/conventions.h"
#include "peis/key.h"

namespace peis::view {
namespace {

std::string textOf(const TupleStore& store, PeisId owner, const std::string& key) {
  const StoredTuple* t = store.find(owner, key);
  return t && !t->deleted && !t->binary ? t->preview : std::string();
}

}  // namespace

std::optional<TupleRef> resolveMetaValue(const std::string& value,
                                         const std::vector<PeerInfo>& peers) {
  const auto dot = value.find('.');
  if (dot == std::string::npos || dot == 0) return std::nullopt;
  const std::string owner = value.substr(0, dot);
  const std::string key = value.substr(dot + 1);
  if (keyProblem(key)) return std::nullopt;
  if (auto id = parsePeisId(owner)) return TupleRef{*id, key};
  std::optional<PeisId> found;
  for (const auto& peer : peers) {
    if (peer.name != owner) continue;
    if (found) return std::nullopt;  // ambiguous
    found = peer.id;
  }
  if (!found) return std::nullopt;
  return TupleRef{*found, key};
}

Graph buildGraph(const std::vector<PeerInfo>& peers, PeisId self, const TupleStore& store) {
  Graph graph;
  std::set<PeisId> reachable;
  for (const auto& peer : peers) reachable.insert(peer.id);
  for (const auto& peer : peers) {
    GraphNode node;
    node.id = peer.id;
    node.name = peer.name;
    node.hops = peer.hops;
    node.tool = peer.tool;
    node.self = peer.id == self;
    node.host = textOf(store, peer.id, "kernel.hostname");
    node.component = textOf(store, peer.id, std::string(conventions::kComponentName));
    node.status = textOf(store, peer.id, std::string(conventions::kStatus));
    node.causes = textOf(store, peer.id, std::string(conventions::kCauseNames));
    graph.nodes.push_back(std::move(node));
  }
  std::sort(graph.nodes.begin(), graph.nodes.end(),
            [](const GraphNode& a, const GraphNode& b) { return a.id < b.id; });

  std::set<std::pair<PeisId, PeisId>> links;
  for (const auto& peer : peers) {
    std::istringstream ids(textOf(store, peer.id, "kernel.links"));
    for (std::string word; ids >> word;) {
      const auto other = parsePeisId(word);
      if (!other || *other == peer.id || !reachable.count(*other)) continue;
      links.insert({std::min(peer.id, *other), std::max(peer.id, *other)});
    }
  }
  graph.links.assign(links.begin(), links.end());

  for (const auto& meta : store.metaInputs()) {
    if (!reachable.count(meta.owner) || meta.binary) continue;
    ConfigurationLink link;
    link.consumer = meta.owner;
    link.metaKey = meta.key;
    link.value = meta.preview;
    if (auto target = resolveMetaValue(meta.preview, peers)) {
      link.producer = target->owner;
      link.producerKey = target->key;
      link.producerReachable = reachable.count(target->owner) > 0;
    }
    graph.configuration.push_back(std::move(link));
  }
  return graph;
}

}  // namespace peis::view
