// Flicker: how far a technique's change from one frame to the next is from the reference's own
// change, per pair of consecutive frames (cell/scoring.cpp scores it where both were scored). A
// per-frame error (FLIP, RMSE) misses flicker: a technique whose error is the same size every
// frame but of a fresh pattern (new photons each frame) scores as well as one whose error stands
// still, yet only the second looks steady in an animation.
//
// For consecutive frames p and c, a technique's images T_p, T_c and the references' means
// R_p, R_c (linear values, the colour channels of every pixel):
//
//   flicker = RMS((T_c - T_p) - (R_c - R_p)) / RMS((R_c + R_p) / 2)
//
// 0 when the technique changes exactly as the reference does (a static, exact sequence, or any
// error that stays in place), whatever the scene does; a technique alternating between R (1 + a)
// and R (1 - a) on a static scene scores 2a. The denominator makes it a relative error, like
// relMSE, so scenes of different brightness compare. The reference's own frame difference is a
// Monte Carlo estimate too: a technique equal to the true images scores, in expectation, the RMS of
// the difference of the two references' noises. Each reference's two half-estimates give a sample
// of its noise with its variance, D = (H1 - H2) / 2 (noise_floor.h), so
//
//   flicker_floor = RMS(D_c - D_p) / RMS((R_c + R_p) / 2)
//
// the floor beside every flicker value, as each score of metrics.csv has one. Not
// sqrt(mean(Var R_c + Var R_p)): the references of consecutive frames are rendered with the same
// sample sequence (the reference seed does not change with the frame), so their noises are
// correlated and largely cancel in R_c - R_p, and D_c - D_p keeps that correlation.
#pragma once

#include "metrics/noise_floor.h"

namespace pb::metrics {

struct Flicker {
  double value = 0;
  double floor = 0;
};

// Throws pb::InputError when the images differ in size or are not all linear (HDR), or a mean is
// zero everywhere (no relative error is defined).
Flicker flicker(const NoisyReference& previous, const NoisyReference& current,
                const io::Image& test_previous, const io::Image& test_current);

}  // namespace pb::metrics
