// The ecology as the view draws it: the PEIS reachable now (from the view's
// routing table), the links between them (every PEIS's `kernel.links`), and
// the configuration: every meta tuple `mi-*` as a link consumer <- producer
// (its value, `OWNER.KEY`, resolved by id or by the name of a reachable
// PEIS). Each PEIS carries its component's name, `status` and
// `cause.names` when it has them. Pure: built from the peers and the store.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "peis/kernel.h"
#include "view/tuple_store.h"

namespace peis::view {

struct GraphNode {
  PeisId id = 0;
  std::string name;
  int hops = 0;
  bool tool = false;
  bool self = false;
  std::string host;       // kernel.hostname, when held
  std::string component;  // component.name
  std::string status;     // status
  std::string causes;     // cause.names
};

struct ConfigurationLink {
  PeisId consumer = 0;
  std::string metaKey;             // mi-brightness
  std::string value;               // the meta tuple's data, as written
  std::optional<PeisId> producer;  // resolved owner, when it resolves
  std::string producerKey;
  bool producerReachable = false;
};

struct Graph {
  std::vector<GraphNode> nodes;                  // ordered by id
  std::vector<std::pair<PeisId, PeisId>> links;  // lower id first, each once
  std::vector<ConfigurationLink> configuration;  // ordered by consumer, key
};

Graph buildGraph(const std::vector<PeerInfo>& peers, PeisId self, const TupleStore& store);

// `OWNER.KEY` of a meta tuple's value, the owner an id or the name of
// exactly one of `peers`; nothing for an empty or malformed value.
std::optional<TupleRef> resolveMetaValue(const std::string& value,
                                         const std::vector<PeerInfo>& peers);

}  // namespace peis::view
