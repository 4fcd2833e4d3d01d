/* Rounded boxes in a pile, step after step: the features of a pair that may touch soon.
 *
 * Written for dem-orchestrator. Two bricks resting on each other keep the same few touching
 * features (vertices, edge pairs: roundedbox_geometry.h) for thousands of steps, while the full
 * search tests all 16 vertices and up to 144 edge pairs every step. Verlet's idea, at the level of
 * features: list the features whose distance is below the reach r_A + r_B plus a skin, and test only
 * those until the two bodies may have moved by the skin (a bound on any point's travel, kept by the
 * pair style). Each listed feature is tested by the same code, with the same culls and in the same
 * order as the full search (boxBoxContacts), so the sub-contacts found are the same to the bit.
 *
 * Why the list holds every feature that can touch: a feature touches only where its distance is
 * below the reach (a vertex: to the other inner box; an edge pair: between the two segments, to
 * 1e-6 of their lengths: edgeAgainstEdge's tolerance at the ends), and a distance between a point of
 * A and a point of B changes by at most the sum of the two bodies' travels.
 */
#ifndef DEMORCH_ROUNDEDBOX_CANDIDATES_H
#define DEMORCH_ROUNDEDBOX_CANDIDATES_H

#include "roundedbox_geometry.h"

namespace RoundedBox {

// Most features listed for one pair (two aligned bricks face on face: 16 touching, a few more near).
const int MAX_CANDIDATES = 40;

/* Distance between segments p0-p1 and q0-q1 (Ericson 2005, Real-Time Collision Detection, 5.1.9). */
inline double segmentDistance(const double *p0, const double *p1, const double *q0, const double *q1)
{
  double d1[3], d2[3], r[3];
  for (int m = 0; m < 3; m++) { d1[m] = p1[m] - p0[m]; d2[m] = q1[m] - q0[m]; r[m] = p0[m] - q0[m]; }
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r), c = dot(d1, r), b = dot(d1, d2);
  const double denominator = a * e - b * b;
  double s = denominator > 1e-30 * a * e ? (b * f - c * e) / denominator : 0.0;
  s = std::min(1.0, std::max(0.0, s));
  double t = (b * s + f) / e;
  if (t < 0.0) { t = 0.0; s = std::min(1.0, std::max(0.0, -c / a)); }
  else if (t > 1.0) { t = 1.0; s = std::min(1.0, std::max(0.0, (b - c) / a)); }
  double gap[3];
  for (int m = 0; m < 3; m++) gap[m] = p0[m] + d1[m] * s - q0[m] - d2[m] * t;
  return std::sqrt(dot(gap, gap));
}

/* Whether segment w0-w1 meets the box of half extents h grown by g (its frame), by clipping the
 * segment to each slab in turn (Liang & Barsky 1984). */
inline bool segmentMeetsBox(const double *w0, const double *w1, const double *h, double g)
{
  double enter = 0.0, leave = 1.0;
  for (int m = 0; m < 3; m++) {
    const double low = -h[m] - g, high = h[m] + g, step = w1[m] - w0[m];
    if (std::fabs(step) < 1e-300) {
      if (w0[m] < low || w0[m] > high) return false;
      continue;
    }
    double t0 = (low - w0[m]) / step, t1 = (high - w0[m]) / step;
    if (t0 > t1) std::swap(t0, t1);
    enter = std::max(enter, t0);
    leave = std::min(leave, t1);
    if (enter > leave) return false;
  }
  return true;
}

/* Keys (roundedbox_geometry.h) of the features of A and B within reach + skin, increasing. Returns
 * how many, or -1 (the pair is then searched in full) when more than MAX_CANDIDATES or where two
 * inner edges may cross. */
inline int candidates(const Box &A, const Box &B, double skin, unsigned char *keys)
{
  Pose p;
  relativeFrame(A, B, p);
  relativeVertices(A, B, p);
  // an edge pair may touch 1e-6 of each edge's length beyond its ends, and the distances here are
  // found to round-off (1e-9 m more: a feature left out is never tested)
  const double longest = std::max(std::max(std::max(A.h[0], A.h[1]), A.h[2]), std::max(std::max(B.h[0], B.h[1]), B.h[2]));
  const double reach = A.r + B.r, within = reach + skin + 4e-6 * longest + 1e-9;
  int n = 0;
  const Box *other[2] = { &B, &A };
  const double (*u[2])[3] = { p.a_in_b, p.b_in_a };
  int code[2][8];
  for (int side = 0; side < 2; side++)
    for (int v = 0; v < 8; v++) {
      const double *w = u[side][v];
      const double *h = other[side]->h;
      double squared = 0.0;
      for (int k = 0; k < 3; k++) {
        const double beyond = std::fabs(w[k]) - h[k];
        if (beyond > 0.0) squared += beyond * beyond;
      }
      code[side][v] = outcode(w, *other[side], within);
      if (squared < within * within) {
        if (n == MAX_CANDIDATES) return -1;
        keys[n++] = static_cast<unsigned char>(8 * side + v);
      }
    }
  // two inner edges that cross (an overlap beyond r_A + r_B) touch at any distance: a pair where an
  // edge of one may come within the skin of the other's inner box is searched in full
  const double deep = skin + 4e-6 * longest + 1e-9;
  for (int side = 0; side < 2; side++)
    for (int e = 0; e < 12; e++) {
      const double *w0 = u[side][edgeStart(e)], *w1 = u[side][edgeEnd(e)];
      const double *h = other[side]->h;
      if (segmentMeetsBox(w0, w1, h, deep)) return -1;
    }
  // edge pairs: both edges near (not beyond one face of the other box grown by `within`), their
  // boxes within `within`, then their distance
  for (int ea = 0; ea < 12; ea++) {
    if (code[0][edgeStart(ea)] & code[0][edgeEnd(ea)]) continue;
    const int ka = ea / 4;
    double a0[3], a1[3];
    for (int m = 0; m < 3; m++) a0[m] = a1[m] = (edgeStart(ea) >> m) & 1 ? A.h[m] : -A.h[m];
    a1[ka] = A.h[ka];
    for (int eb = 0; eb < 12; eb++) {
      if (code[1][edgeStart(eb)] & code[1][edgeEnd(eb)]) continue;
      const double *b0 = p.b_in_a[edgeStart(eb)], *b1 = p.b_in_a[edgeEnd(eb)];
      bool apart = false;
      for (int m = 0; m < 3 && !apart; m++)
        apart = std::min(a0[m], a1[m]) > std::max(b0[m], b1[m]) + within || std::max(a0[m], a1[m]) < std::min(b0[m], b1[m]) - within;
      if (apart || segmentDistance(a0, a1, b0, b1) >= within) continue;
      if (n == MAX_CANDIDATES) return -1;
      keys[n++] = static_cast<unsigned char>(16 + 12 * ea + eb);
    }
  }
  return n;
}

/* The sub-contacts among the listed features, exactly as boxBoxContacts finds them (the same tests,
 * culls and order). Returns how many were written to out. */
inline int candidateContacts(const Box &A, const Box &B, const unsigned char *keys, int count, SubContact *out)
{
  Pose p;
  relativeFrame(A, B, p);
  Axes x;
  relativeAxes(A, B, p, x);
  // the vertices the listed features need, each made once: bit v of made_a (A's in B's frame), of made_b
  int made_a = 0, made_b = 0;
  const double reach = A.r + B.r;
  int n = 0;
  for (int c = 0; c < count; c++) {
    const int key = keys[c];
    if (key < 16) {
      const bool of_a = key < 8;
      const int v = key & 7;
      double *u = of_a ? p.a_in_b[v] : p.b_in_a[v];
      int &made = of_a ? made_a : made_b;
      if (!(made >> v & 1)) {
        vertexInOther(of_a ? x.a_centre : p.t, of_a ? x.a_axes : x.b_axes, v, u);
        made |= 1 << v;
      }
      const Box &other = of_a ? B : A;
      if (!outcode(u, other, reach) && vertexAgainstBox(u, of_a ? A.r : B.r, other, !of_a, key, out[n])) n++;
      continue;
    }
    const int ea = (key - 16) / 12, eb = (key - 16) % 12;
    const int ends[4] = { edgeStart(ea), edgeEnd(ea), edgeStart(eb), edgeEnd(eb) };
    for (int e = 0; e < 2; e++) {
      if (!(made_a >> ends[e] & 1)) { vertexInOther(x.a_centre, x.a_axes, ends[e], p.a_in_b[ends[e]]); made_a |= 1 << ends[e]; }
      if (!(made_b >> ends[2 + e] & 1)) { vertexInOther(p.t, x.b_axes, ends[2 + e], p.b_in_a[ends[2 + e]]); made_b |= 1 << ends[2 + e]; }
    }
    if (outcode(p.a_in_b[ends[0]], B, reach) & outcode(p.a_in_b[ends[1]], B, reach)) continue;
    if (outcode(p.b_in_a[ends[2]], A, reach) & outcode(p.b_in_a[ends[3]], A, reach)) continue;
    EdgeBox box;
    edgeBox(A, p, eb, box);
    if (edgePairMayTouch(A, ea, box, reach) && edgeAgainstEdge(A, ea, B, eb, p, key, out[n])) n++;
  }
  return n;
}

}  // namespace RoundedBox

#endif
