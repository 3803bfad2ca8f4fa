// Watching one tuple, its current value included (tuple_watch.h).
#include "tuple_watch.h"

namespace peis::scenario {

void TupleWatch::Shared::hand(const Tuple* t) {
  // Held while handing on, so the cached value and a newer change that
  // races it arrive in order.
  std::lock_guard lock(mu);
  if (t) {
    if (t->seqno <= lastSeqno) return;  // already handed on
    lastSeqno = t->seqno;
  } else {
    lastSeqno = 0;  // deleted: a value written again starts over at any seqno
  }
  onValue(t);
}

TupleWatch::TupleWatch(Kernel& kernel, PeisId owner, std::string key, Callback onValue)
    : shared_(std::make_shared<Shared>()) {
  shared_->onValue = std::move(onValue);
  auto shared = shared_;
  kernel.onChange(Pattern::exact(owner, key), [shared](const Tuple& t) { shared->hand(&t); });
  kernel.onDelete(Pattern::exact(owner, key), [shared](const Tuple&) { shared->hand(nullptr); });
  kernel.subscribe(Pattern::exact(owner, key));
  // What another subscription brought before the callbacks existed.
  if (const auto cached = kernel.get(owner, key)) shared->hand(&*cached);
}

}  // namespace peis::scenario
