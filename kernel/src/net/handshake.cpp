// The handshake's decision; see handshake.h.
#include "net/handshake.h"

namespace peis::net {

HelloVerdict judgeHello(const HelloContext& c, const wire::Hello& hello) {
  if (c.established) return HelloVerdict::Ignore;
  if (hello.version != wire::kVersion) return HelloVerdict::WrongVersion;
  if (hello.ecology != c.ecology) return HelloVerdict::ForeignEcology;
  if (hello.id == c.self) {
    if (hello.incarnation == c.incarnation) return HelloVerdict::Myself;
    // The PEIS with the smaller incarnation (started earlier) keeps the id.
    if (c.incarnation < hello.incarnation) return HelloVerdict::IdMine;
    return c.mayGiveUpId ? HelloVerdict::IdTheirs : HelloVerdict::IdKept;
  }
  if (c.existing) {
    if (c.existing->incarnation != hello.incarnation) return HelloVerdict::OtherIncarnationLinked;
    // Keep the link the lower id dialled, so both ends keep the same one.
    const bool keepNew = (c.self < hello.id) == c.outbound;
    if (!keepNew || c.existingOutbound == c.outbound) return HelloVerdict::Duplicate;
    return HelloVerdict::ReplacesExisting;
  }
  return HelloVerdict::Establish;
}

}  // namespace peis::net
