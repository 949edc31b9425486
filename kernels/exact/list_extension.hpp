// A neighbour list extended body by body instead of rebuilt (the exact method on one rank).
//
// A list expires when a body's motion bound reaches half the skin (neighbor_list_expired):
// the fastest of all bodies sets the list's life. In a dense fluid that is a few bodies in
// thousands: hard spheres at packing fraction 0.45 (N = 32768, dt 4e-3, skin 0.5) reach it at
// step 13, when the median body has used under half of its share; 1 % of the bodies have at
// step 19. As event-driven MD renews one body's neighbour list when it leaves its shell, this
// gives each body its own reach (half the skin, plus its `extra_reach`) and extends the reach
// of the bodies that (nearly) used theirs, listing their new partners, until so many have
// that a build is cheaper.
//
// What keeps it exact: a pair the list does not hold had, at the build, a distance of at least
// D + reach_a + reach_b. The build lists every pair below D + skin (both reaches half the
// skin), and an extension of body a to reach r lists every pair whose distance at the build
// was below D + r + reach_b, measured from the centres and axes kept at the build
// (ListExtension::built) and found through the build's cells around a's (centres then within
// L + D + r + the largest reach). A pair's distance shrinks by at most the two bounds, so a
// pair left out cannot touch while each body's bound is below its reach. The list and its
// slacks decide only which pairs are measured: what touches, and so the trajectory, is the
// same bit for bit as with a build at every expiry.
//
// New pairs go to the end of the list, due at once (their slack is -infinity: the next
// detection measures them). Their ends go to the by-body index: the extended body's run and
// each new partner's are moved to the end of pair_index and pair_partner, and pairs_end
// (not pairs_start[b + 1]) then bounds a body's run. The new pairs join the near pairs
// (NearPairs: they are due), at the end as in the list. The watches are dropped until the
// next build (their allowances do not cover the new pairs), so the detection passes over the
// pairs. One rank without shadows only: a shadow's partners lie on other ranks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// What the extensions of one list need beyond the list itself: the bodies' centres (and rods'
// axes) at the build, which an extension measures, and each body's reach beyond half the skin.
struct ListExtension {
  struct {
    std::vector<double> x, y, z, ex, ey, ez;
  } built;
  // [0, active), 0 after a build, and the largest.
  std::vector<double> extra_reach;
  double largest_extra = 0.0;
  long long extended = 0;    // extensions since the build
  long long extensions = 0;  // all (a statistic)
};

// After a build of `list` over bodies p of which [0, owned) are owned: their centres and axes
// kept and every extra reach zero where there are no shadows (one rank), else nothing kept (no
// extension then).
void start_extension(ListExtension &ext, const NeighborList &list, const Particles &p,
                     std::size_t owned, const Shape &shape);

// Body b's reach beyond half the skin (0 until an extension, or where none is kept).
inline double extra_reach(const ListExtension &ext, std::uint32_t b) {
  return b < ext.extra_reach.size() ? ext.extra_reach[b] : 0.0;
}

// Extends the reach of every body of [0, list.active) whose motion bound is within `lead` of
// it (by whole halves of the skin, past its bound and the lead), listing the pairs the new
// reaches need. The lead keeps a body that speeds up within the step from outrunning its
// reach there (which would have the step solved again). Returns false, changing nothing,
// where a build is due instead: the list has shadows (several ranks), more than `budget`
// extensions since its build would be needed, or a body due is a runaway (its step, 2 grow,
// takes half the skin, or its bound and lead reach twice the skin), which the build's checks
// take.
bool extend_neighbor_list(NeighborList &list, ListExtension &ext, const Particles &p,
                          const Box &box, const Shape &shape, double lead, long long budget);

}  // namespace hardrod
