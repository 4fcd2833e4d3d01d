/* Rounded boxes touching rounded boxes, several contact points per pair, for LIGGGHTS 3.8.
 *
 * Written for dem-orchestrator:  pair_style roundedbox rounding R   and   pair_coeff * *
 * Bodies are atoms of `atom_style superquadric` (the source-built LIGGGHTS): `shape` gives the
 * outer half extents, the inner box is shape - R, the quaternion its orientation; blockiness,
 * the superquadric's own volume and radius play no part. Every sub-contact between two bodies
 * (roundedbox_geometry.h) carries the law of roundedbox_law.h with the type pair's constants from
 * the same `fix property/global` matrices as `pair_style gran model bilinear`: kn, kt,
 * coefficientRestitutionSquared, coefficientFriction. Needs `newton off`. Histories live in a
 * fix roundedbox/history (ID roundedbox_history) that this pair style creates.
 */
#ifdef PAIR_CLASS

PairStyle(roundedbox,PairRoundedBox)

#else

#ifndef DEMORCH_PAIR_ROUNDEDBOX_H
#define DEMORCH_PAIR_ROUNDEDBOX_H

#include <vector>
#include "pair.h"
#include "roundedbox_candidates.h"
#include "roundedbox_law.h"

namespace LAMMPS_NS {

class PairRoundedBox : public Pair {
 public:
  PairRoundedBox(class LAMMPS *);
  ~PairRoundedBox();
  void compute(int, int);
  void settings(int, char **);
  void coeff(int, char **);
  void init_style();
  double init_one(int, int);
  // the contact constants of a type pair, and a body as a rounded box (also used by fix wall/roundedbox)
  static void read_constants(class LAMMPS *, const char *caller, int ntypes, RoundedBox::Constants **&table);
  static void body(class Atom *, int i, double rounding, RoundedBox::Box &box);

 protected:
  double rounding_;
  double reach_;  // largest distance from a centre to its surface, over all bodies (m)
  RoundedBox::Constants **constants_;
  class FixRoundedBoxHistory *history_;
  std::vector<RoundedBox::Box> boxes_;  // per local and ghost body, remade each step
  // Verlet's idea with a motion bound: since the last neighbour list, how far any point of each body
  // may have moved (m), from its centre's travel and its rotation (travel_); per neighbour-list
  // entry, what was known of the pair and the two bodies' travel then. A pair found apart is tested
  // again once their travels since could close that distance; a pair near or touching keeps the
  // features within the reach plus skin_ (roundedbox_candidates.h: a list in lists_) until their
  // travels since could exceed the skin, sized so that a list lasts about LIST_STEPS steps.
  static const int LIST_STEPS = 20;
  struct Entry {
    double apart;          // a lower bound of the distance when found apart (m), else -1
    double travel;         // the two bodies' travel then (m)
    double skin;           // the skin its list was made with (m)
    int list;              // index of its list in lists_ (-1: none; count first, then the keys)
    bool listed;           // the list holds the features within reach of `travel`
  };
  double skin_;           // the least skin (m); a pair moving fast gets more (compute)
  std::vector<double> travel_, step_, last_x_, last_q_;  // step_: each body's travel bound over the last step (m)
  std::vector<Entry> entries_;
  std::vector<unsigned char> lists_;
  void track_motion(int nall, bool rebuilt);
  void allocate();
};

}

#endif
#endif
