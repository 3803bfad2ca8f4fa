// Test helper: tuples as another owner would have stamped them, to feed a
// TupleSpace or Replication as if they had come over the network.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "peis/tuple.h"

namespace peis::test {

inline Tuple remoteTuple(PeisId owner, std::string key, std::string data, std::uint64_t seqno,
                         std::string mimetype = kDefaultMimetype) {
  Tuple tuple;
  tuple.owner = owner;
  tuple.creator = owner;
  tuple.key = std::move(key);
  tuple.data = std::move(data);
  tuple.mimetype = std::move(mimetype);
  tuple.ts_write = Timestamp(std::chrono::seconds(1'600'000'000));
  tuple.seqno = seqno;
  return tuple;
}

}  // namespace peis::test
