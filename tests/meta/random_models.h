// Random models for tests and benchmarks: small ones for the exhaustive
// check (sharing, variables, preconditions, cycles, dead PEIS), and the two
// benchmark families of docs/performance.md (sensing, layered).
#pragma once

#include <cstdint>
#include <random>

#include "peis/meta/goals.h"
#include "peis/meta/model.h"

namespace peis::meta::testing {

struct Problem {
  Model model;
  Goals goals;
};

// A few PEIS, 2-8 functionalities, typed ports with variables bound by facts,
// shared producers, alternative producers, cycles possible.
Problem smallRandom(std::mt19937& rng);

// Tiny layered models where producers are shared: 2-3 layers of types,
// 1-3 producers per type on 2-4 PEIS (local, LAN and radio links, so one
// slot's producers differ in link cost), 1-6 goals; no cycle can form.
// At most about 9 functionalities, for the exhaustive search.
Problem smallShared(std::mt19937& rng);

// Sensing (after the ecare@home benchmark): sensors, and inference
// functionalities that derive a concept (`activity(?p, room)`) from 1-5
// sensed concepts; a few alternative inferences per concept; goals ask for
// concepts. About `functionalities` functionalities in all.
Problem sensing(std::mt19937& rng, int functionalities);

// Layered: types in 5 layers, 1-3 producers per type, each consuming 1-3
// types of the layer below; 1-20 goals on the top layer delivered to consumers
// on several PEIS, sharing producers.
Problem layered(std::mt19937& rng, int functionalities, int goals = 0);

}  // namespace peis::meta::testing
