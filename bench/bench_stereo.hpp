// bench_stereo's sections (issue 16 point 3(b), issue 17): each prints its own markdown table of
// DSMs made by dsmplan's pipelines against a known truth, dsmplan's SGM beside OpenCV's
// StereoSGBM plugged into the same pipeline. bench_stereo.cpp runs them in turn.
#pragma once

namespace bench {

/// Frame cameras: synthetic aerial views rendered from the real NRW DSM (bench_stereo_frames.cpp).
/// `rounds`: timed, interleaved rounds per set-up.
void frame_camera_table(int rounds);
void block_table(int rounds);  ///< issue 34 point 5: the rendered blocks, dsmplan against OpenCV
void range_cost_table();       ///< issue 34 point 2: the blocks' DSMs with the estimated range and the true one

}  // namespace bench
