// The bodies a run starts from (init.configuration, docs/physics.md section 6): on the aligned
// lattice, compressed from a random isotropic state, or a frame of a file (H5MD or GSD), all
// n in id order and the same on every rank. Every start from a file passes one set of checks,
// with one set of messages naming init.file and the frame: the count, the box, and no overlap
// beyond run.max_overlap. Velocities: a GSD frame's own if it has any; else fresh at
// init.temperature.
#pragma once

#include "kernels/particles.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

// Throws SceneError naming the key. `stoppable`: a stop signal ends a long set-up (the
// isotropic compression) with CompressionStopped; only on one rank, where no other rank can be
// left waiting. `report`: its progress printed every few seconds.
Particles initial_bodies(const Scene &scene, bool stoppable = false, bool report = false);

}  // namespace hardrod
