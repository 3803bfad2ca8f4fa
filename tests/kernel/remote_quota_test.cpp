// Unit tests of RemoteQuota (remote_quota.h) and of the OwnerGuard's
// refusals (owner_guard.h): keys and bytes per remote writer and in total,
// what frees them, and the kernel's own tuples.
#include "remote_quota.h"

#include <catch2/catch.hpp>

#include "owner_guard.h"

using peis::RemoteQuota;

TEST_CASE("quota: keys and bytes per writer and in total", "[unit]") {
  RemoteQuota quota(RemoteQuota::Limits{2, 100, 3, 105});
  CHECK_FALSE(quota.check("a", "k1", 10, "A"));
  quota.onChanged("k1", "a", 10);
  quota.onChanged("k2", "a", 10);
  CHECK(quota.check("a", "k3", 1, "A")->find("--peis-quota-keys") != std::string::npos);
  CHECK_FALSE(quota.check("a", "k1", 90, "A"));  // its own key: bytes only
  CHECK(quota.check("a", "k1", 91, "A")->find("--peis-quota-bytes") != std::string::npos);
  quota.onChanged("k3", "b", 10);
  CHECK(quota.check("b", "k4", 1, "B")->find("--peis-quota-total-keys") != std::string::npos);
  // Taking over another writer's key moves it (no new key in total).
  CHECK_FALSE(quota.check("b", "k2", 10, "B"));
  CHECK(quota.check("b", "k2", 90, "B")->find("--peis-quota-total-bytes") != std::string::npos);
  // The owner's own write, or a deletion, frees what a writer held.
  quota.onChanged("k1", "", 5);
  quota.onDeleted("k2");
  CHECK(quota.heldBy("a").keys == 0);
  CHECK(quota.total().keys == 1);
  CHECK_FALSE(quota.check("a", "k5", 1, "A"));
}

TEST_CASE("owner guard: the kernel's tuples, and kernel.do-quit set only", "[unit]") {
  peis::OwnerGuard guard(peis::Limits{});
  peis::wire::Write write;
  write.tuple.owner = 7;
  write.tuple.key = "kernel.name";
  auto refusal = guard.checkWrite(7, 9, write, nullptr);
  REQUIRE(refusal);
  CHECK(refusal->code() == peis::ErrorCode::Refused);
  write.tuple.key = "kernel.do-quit";
  CHECK_FALSE(guard.checkWrite(7, 9, write, nullptr));
  write.op = peis::wire::WriteOp::Erase;
  CHECK(guard.checkWrite(7, 9, write, nullptr));
  CHECK(guard.stats().kernelTupleRefused == 2);
  CHECK(guard.takeDeniedText()->find("2 denied") == 0);
  CHECK_FALSE(guard.takeDeniedText());
}
