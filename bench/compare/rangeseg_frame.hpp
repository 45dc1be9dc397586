// rangeseg's frame as `rangeseg bench` times it (preset kinect, one smoothing pass, after a first
// frame), for the comparison benchmarks: the frame's time, and its stages' means as counters [ms].
#pragma once

#include <benchmark/benchmark.h>

#include "rangeseg/pipeline.hpp"

namespace rangeseg::compare {

/// `first_stage` names StageTimes::mesh in the counters: "mesh_ms", or "rings_ms" for an
/// unorganized cloud.
inline void time_rangeseg_frame(benchmark::State& state, const OrganizedCloud& cloud,
                                const char* first_stage) {
  PipelineSettings settings = pipeline_preset("kinect");
  settings.smoothing.iterations = 1;
  Pipeline pipeline(settings);
  pipeline.process(cloud);  // the first frame allocates the buffers; the others reuse them
  StageTimes sum;
  for (auto _ : state) {
    pipeline.process(cloud);
    const StageTimes& t = pipeline.times();
    sum.mesh += t.mesh;
    sum.normals += t.normals;
    sum.smoothing += t.smoothing;
    sum.segmentation += t.segmentation;
    sum.polygons += t.polygons;
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters[first_stage] = sum.mesh / n;
  state.counters["normals_ms"] = sum.normals / n;
  state.counters["smoothing_ms"] = sum.smoothing / n;
  state.counters["segmentation_ms"] = sum.segmentation / n;
  state.counters["polygons_ms"] = sum.polygons / n;
}

}  // namespace rangeseg::compare
