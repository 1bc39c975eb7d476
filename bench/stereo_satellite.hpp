// The satellite half of the stereo benchmark (issue 17): `dsmplan stereo IMG1 IMG2` on the whole
// Pléiades crops of data/pleiades-kahramanmaras (bench/stereo_satellite.cpp): the `bench_stereo`
// binary runs it after the frame-camera rows (`bench_stereo ROUNDS satellite`: alone).
#pragma once

/// Runs every pair `rounds` times (interleaved: each round runs both pairs once), prints a row per
/// pair (seconds per stage as the median over the rounds with min-max, DSM cells per second,
/// each round's 1-minute load average) and the checks of the two DSMs against each other
/// (median |pre - post|, share over 1 m, completeness). Returns 0, or 1 when a run failed.
int run_satellite_stereo_bench(int rounds);
