// GgxUpdater (issue 34 §2): a GGX chain that follows a changing environment recomputes only the
// tiles a change reaches, stays within its tolerance of a fresh chain, and judges against the
// last completed chain after a cancelled update.
#include <gtest/gtest.h>

#include <filesystem>
#include <numbers>
#include <stop_token>

#include "../support/env_fixtures.hpp"
#include "arlight/common/hdr_io.hpp"
#include "updater_fixtures.hpp"
#include "arlight/common/resample.hpp"
#include "arlight/lighting/ggx.hpp"

using namespace arlight;
using namespace arlight::lighting;
using test::scale_cap;

namespace {

// venice as a face-64 cube map (for 128^2 maps the wide lobes then go through SH).
EnvMap venice() { return test::venice_cube64(); }

const GgxChainSpec kSpec{.face = 64, .min_face = 8};

void expect_chains_near(const GgxChain& fresh, const GgxChain& got, double mean, double max) {
  ASSERT_EQ(fresh.levels.size(), got.levels.size());
  for (std::size_t k = 0; k < fresh.levels.size(); ++k) {
    const MapError e = map_error(fresh.levels[k].map, got.levels[k].map);
    EXPECT_LE(e.mean, mean) << "level " << k;
    EXPECT_LE(e.max, max) << "level " << k;
  }
}

}  // namespace

TEST(GgxUpdater, TheFirstUpdateIsTheWholeChainAndAnUnchangedRoomKeepsIt) {
  GgxUpdater updater(kSpec);
  const GgxChain first = updater.update(venice());
  const GgxChain fresh = compute_ggx_chain(venice(), kSpec);
  expect_chains_near(fresh, first, 0.0, 0.0);
  ASSERT_EQ(updater.recomputed().size(), 4u);
  for (double r : updater.recomputed()) EXPECT_EQ(r, 1.0);
  const GgxChain& again = updater.update(venice());
  expect_chains_near(first, again, 0.0, 0.0);
  for (double r : updater.recomputed()) EXPECT_EQ(r, 0.0);
  EXPECT_EQ(updater.changed(), 0.0);
}

// A lamp switched on in one part of the room: the glossy levels recompute what it can reach,
// and the chain stays within the 2 % tolerance of a fresh one of the new room.
TEST(GgxUpdater, ALocalChangeRecomputesOnlyWhatItReaches) {
  GgxUpdater updater(kSpec, 0.02);
  EnvMap env = venice();
  updater.update(env);
  const double share = scale_cap(env, glm::normalize(glm::dvec3(0.6, 0.2, -0.7)), 0.15, 4.0f);
  ASSERT_GT(share, 0.003);
  const GgxChain& after = updater.update(env);
  EXPECT_NEAR(updater.changed(), share, 0.01);
  const GgxChain fresh = compute_ggx_chain(env, kSpec);
  expect_chains_near(fresh, after, 0.002, 0.02);
  // Level 1 (roughness 0.18) is narrow: most of it stays; the roughest level sees the lamp
  // from everywhere above its horizon.
  EXPECT_GT(updater.recomputed()[1], 0.0);
  EXPECT_LT(updater.recomputed()[1], 0.6);
  EXPECT_GT(updater.recomputed()[3], updater.recomputed()[1]);
}

// What a tile skips adds up: a slow brightening of one region never moves the chain more than
// the tolerance from a fresh one, however many steps it takes.
TEST(GgxUpdater, SkippedChangesAddUpUntilTheyCount) {
  GgxUpdater updater(kSpec, 0.02);
  EnvMap env = venice();
  updater.update(env);
  const glm::dvec3 centre = glm::normalize(glm::dvec3(-0.3, 0.8, 0.2));
  double skipped = 0.0;
  for (int step = 0; step < 8; ++step) {
    scale_cap(env, centre, 0.3, 1.5f);
    const GgxChain& now = updater.update(env);
    skipped += 1.0 - updater.recomputed()[2];
    expect_chains_near(compute_ggx_chain(env, kSpec), now, 0.003, 0.025);
  }
  EXPECT_GT(skipped, 0.5);  // it did skip tiles on the way
}

TEST(GgxUpdater, ACancelledUpdateLeavesTheLastChainToJudgeAgainst) {
  GgxUpdater updater(kSpec);
  EnvMap env = venice();
  updater.update(env);
  scale_cap(env, glm::dvec3(0, 1, 0), 0.3, 3.0f);
  EXPECT_THROW(updater.update(env, test::stopped_hooks()), Cancelled);
  const GgxChain& after = updater.update(env);
  EXPECT_GT(updater.changed(), 0.0);  // the change is still seen as one
  expect_chains_near(compute_ggx_chain(env, kSpec), after, 0.002, 0.02);
}

TEST(GgxUpdater, BadSpecsAndInputsSayWhatIsWrong) {
  EXPECT_THROW(GgxUpdater(GgxChainSpec{.face = 48}), InputError);
  EXPECT_THROW(GgxUpdater(kSpec, -1.0), std::invalid_argument);
  GgxUpdater updater(kSpec);
  const std::vector<float> wrong(5, 1.0f);
  EXPECT_THROW(updater.update(venice(), {}, wrong), std::invalid_argument);
}
