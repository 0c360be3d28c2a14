/// The tracking state of every frame (localise/tracking_judge.hpp): good, poor or lost, from the
/// ICP's evidence; in FrameResult and stats.json (counts and stretches). It only observes: the
/// trajectory of `exact` is the same with it (test_api's byte-for-byte CLI comparison and the
/// reference parity tests cover that).

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "kfx/kfx.hpp"
#include "localise/tracking_judge.hpp"
#include "support/cli_runner.hpp"
#include "support/test_dir.hpp"

namespace kfx {
namespace {

TrackingEvidence tracked(float constraint) { return {true, true, constraint}; }
constexpr float kWeak = TrackingJudge::kWeakConstraint * 0.5f;
constexpr float kStrong = TrackingJudge::kWeakConstraint * 2.0f;

TEST(TrackingJudge, LostWhenTheAcceptTestFailsGoodWhenTrackedAgain) {
  TrackingJudge judge;
  EXPECT_EQ(judge.judge({false, false, 0}), TrackingQuality::kGood);  // bootstrap: pose given
  EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kGood);
  EXPECT_EQ(judge.judge({true, false, kStrong}), TrackingQuality::kLost);
  EXPECT_EQ(judge.judge({false, false, 0}), TrackingQuality::kLost);  // no tracking: kept
  EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kGood);
}

TEST(TrackingJudge, AStretchOfWeakFramesIsPoorAShortOneIsNot) {
  TrackingJudge judge;
  for (int i = 0; i < TrackingJudge::kWeakFramesToPoor - 1; ++i) {
    EXPECT_EQ(judge.judge(tracked(kWeak)), TrackingQuality::kGood) << i;
  }
  EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kGood);  // the run is broken
  for (int i = 0; i < TrackingJudge::kWeakFramesToPoor - 1; ++i) judge.judge(tracked(kWeak));
  EXPECT_EQ(judge.judge(tracked(kWeak)), TrackingQuality::kPoor);
  EXPECT_EQ(judge.judge(tracked(kWeak)), TrackingQuality::kPoor);
  for (int i = 0; i < TrackingJudge::kStrongFramesToGood - 1; ++i) {
    EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kPoor) << i;
  }
  EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kGood);
}

TEST(TrackingJudge, ALoadedMapStartsLostUntilTracked) {
  TrackingJudge judge(true);
  EXPECT_EQ(judge.current(), TrackingQuality::kLost);
  EXPECT_EQ(judge.judge({false, false, 0}), TrackingQuality::kLost);
  EXPECT_EQ(judge.judge(tracked(kStrong)), TrackingQuality::kGood);
  judge.restart(false);
  EXPECT_EQ(judge.current(), TrackingQuality::kGood);
}

TEST(TrackingTimeline, CountsStatesAndStretchesOfPoorAndLost) {
  TrackingTimeline t;
  const TrackingQuality g = TrackingQuality::kGood, p = TrackingQuality::kPoor,
                        l = TrackingQuality::kLost;
  int frame = 0;
  for (TrackingQuality q : {g, p, p, l, l, l, g, p}) t.add(frame++ * 2, q);
  EXPECT_EQ(t.count(g), 2);
  EXPECT_EQ(t.count(p), 3);
  EXPECT_EQ(t.count(l), 3);
  ASSERT_EQ(t.stretches().size(), 3u);
  EXPECT_EQ(t.stretches()[0].quality, p);
  EXPECT_EQ(t.stretches()[0].first_frame, 2);
  EXPECT_EQ(t.stretches()[0].last_frame, 4);
  EXPECT_EQ(t.stretches()[0].frames, 2);
  EXPECT_EQ(t.stretches()[1].quality, l);
  EXPECT_EQ(t.stretches()[1].first_frame, 6);
  EXPECT_EQ(t.stretches()[1].last_frame, 10);
  EXPECT_EQ(t.stretches()[2].first_frame, 14);
}

// A jump and a blank stretch: the frames whose tracking fails are lost in FrameResult, in the
// same number as stats.json's "lost", in stretches that cover them.
TEST(TrackingState, LostFramesAreReportedInResultsAndStats) {
  const std::string input =
      "synthetic:frames=40,width=128,height=96,noise=0,jump=15-18,blank=28-31";
  Sequence sequence(input);
  Reconstruction r(Settings().backend("cpu").set("volume_resolution", "64"), sequence);
  SequenceFrame frame;
  std::vector<int> lost;
  while (sequence.next(frame) == ReadStatus::kOk) {
    const FrameResult result = r.process(frame);
    EXPECT_EQ(result.tracking_quality == TrackingQuality::kLost,
              result.tracking_ran && !result.tracked)
        << "frame " << result.index;
    if (result.tracking_quality == TrackingQuality::kLost) lost.push_back(result.index);
  }
  ASSERT_FALSE(lost.empty());
  EXPECT_GE(lost.front(), 15);
  EXPECT_LE(lost.back(), 31);

  const auto dir = test::fresh_test_dir("kfx_state_");
  const auto cli = test::run_kfx("run '" + input + "' --backend cpu -v 64 --no-mesh --no-report " +
                                 "--out " + (dir / "out").string());
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  EXPECT_NE(cli.output.find("), lost "), std::string::npos) << cli.output;  // progress line
  std::ifstream in(dir / "out" / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(in);
  const nlohmann::json& states = stats.at("tracking_states");
  EXPECT_EQ(states.at("lost").get<int>(), static_cast<int>(lost.size()));
  EXPECT_EQ(states.at("lost").get<int>(), stats.at("lost").get<int>());
  EXPECT_EQ(
      states.at("good").get<int>() + states.at("poor").get<int>() + states.at("lost").get<int>(),
      stats.at("frames").get<int>());
  int in_stretches = 0;
  for (const auto& s : states.at("stretches")) {
    if (s.at("state") == "lost") in_stretches += s.at("frames").get<int>();
    EXPECT_LE(s.at("first_frame").get<int>(), s.at("last_frame").get<int>());
  }
  EXPECT_EQ(in_stretches, static_cast<int>(lost.size()));
}

}  // namespace
}  // namespace kfx
