/* The contact law of Richefeu, Mollon, Daudon & Villard (2012) at one sub-contact of a rounded box.
 *
 * Written for dem-orchestrator; the same law as normal_model_bilinear.h, at every contact point:
 *   normal, overlap h >= 0:  loading (h >= h_prev)  f_n = f_n,prev + k_n (h - h_prev)
 *                            unloading (h < h_prev) f_n = e_n^2 k_n h, never below 0
 *   tangential: an incremental spring, f_t += -k_t v_t dt, turned into the current tangent plane
 *   (its magnitude kept) and capped at mu f_n (Coulomb). No viscous damping: an impact loses
 *   exactly 1 - e_n^2 of its normal kinetic energy.
 * A sub-contact met for the first time (or after it was lost) starts from f_n = 0, h_prev = 0, f_t = 0.
 */
#ifndef DEMORCH_ROUNDEDBOX_LAW_H
#define DEMORCH_ROUNDEDBOX_LAW_H

#include <cmath>
#include "roundedbox_geometry.h"

namespace RoundedBox {

struct History {
  double fn;       // normal force (N)
  double overlap;  // overlap at that step (m)
  double ft[3];    // tangential force on A (N, world)
};

struct Constants {
  double kn, kt, en2, mu;  // N/m, N/m, 1, 1
};

/* The force on A (world, N) at sub-contact `s`, from the velocity of A's material point relative
 * to B's there (`relative`, m/s), the previous history (`previous`, NULL if none) and the time step;
 * `next` receives the history to keep. */
inline void subContactForce(const SubContact &s, const double *relative, const Constants &k, double dt,
                            const History *previous, History &next, double *force)
{
  const double *n = s.normal;
  const double h = s.overlap;
  const double fn_prev = previous ? previous->fn : 0.0;
  const double h_prev = previous ? previous->overlap : 0.0;
  double fn = h >= h_prev ? fn_prev + k.kn * (h - h_prev) : k.en2 * k.kn * h;
  if (fn < 0.0) fn = 0.0;

  double ft[3] = { 0.0, 0.0, 0.0 };
  if (previous) {
    for (int i = 0; i < 3; i++) ft[i] = previous->ft[i];
    const double before = std::sqrt(dot(ft, ft));
    const double along = dot(ft, n);
    for (int i = 0; i < 3; i++) ft[i] -= along * n[i];
    const double after = std::sqrt(dot(ft, ft));
    if (after > 0.0) for (int i = 0; i < 3; i++) ft[i] *= before / after;
  }
  const double vn = dot(relative, n);
  for (int i = 0; i < 3; i++) ft[i] -= k.kt * (relative[i] - vn * n[i]) * dt;
  const double magnitude = std::sqrt(dot(ft, ft));
  const double cap = k.mu * fn;
  if (magnitude > cap) {
    const double scale = magnitude > 0.0 ? cap / magnitude : 0.0;
    for (int i = 0; i < 3; i++) ft[i] *= scale;
  }
  next.fn = fn;
  next.overlap = h;
  for (int i = 0; i < 3; i++) {
    next.ft[i] = ft[i];
    force[i] = fn * n[i] + ft[i];
  }
}

}  // namespace RoundedBox

#endif
