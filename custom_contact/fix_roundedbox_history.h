/* Per-atom contact history of rounded boxes (pair roundedbox, fix wall/roundedbox), for LIGGGHTS 3.8.
 *
 * Written for dem-orchestrator. Each atom keeps one slot per sub-contact it is part of: the partner
 * (another atom's tag, or a wall triangle), the sub-contact's key (roundedbox_geometry.h) and its
 * History (roundedbox_law.h). A force computation reads the slots of the last step and writes this
 * step's: a sub-contact that is no longer touching is dropped, one that appears starts afresh. The
 * slots travel with their atom between processes and into restart files, so a continued run
 * carries every sub-contact's history; both atoms of a pair keep the same slot, which makes the
 * history independent of which process computes the pair.
 * Created by the pair or wall fix that uses it (style roundedbox/history); not for input scripts.
 */
#ifdef FIX_CLASS

FixStyle(roundedbox/history,FixRoundedBoxHistory)

#else

#ifndef DEMORCH_FIX_ROUNDEDBOX_HISTORY_H
#define DEMORCH_FIX_ROUNDEDBOX_HISTORY_H

#include <vector>
#include "fix.h"
#include "roundedbox_law.h"

namespace LAMMPS_NS {

class FixRoundedBoxHistory : public Fix {
 public:
  struct Slot {
    double partner;  // partner's atom tag, or a wall triangle's code (fix wall/roundedbox)
    int key;
    RoundedBox::History history;
  };
  static const int SLOT_DOUBLES = 7;  // partner, key, fn, overlap, ft[3]
  static const int MAX_SLOTS = 256;   // per atom: a brick in a dense pile has a few dozen

  FixRoundedBoxHistory(class LAMMPS *, int, char **);
  ~FixRoundedBoxHistory();
  int setmask() { return 0; }

  // one force computation: begin, then look up and store per sub-contact, then commit
  void begin(int nlocal);
  const RoundedBox::History *find(int i, double partner, int key) const;
  // the slots of atom i with one partner atom, in increasing key order: [*first, *last)
  void partner_slots(int i, double partner, const Slot *&first, const Slot *&last) const;
  void store(int i, double partner, int key, const RoundedBox::History &history);
  void commit(int nlocal);
  int touching(int i) const { return static_cast<int>(current_[i].size()); }

  void grow_arrays(int);
  void copy_arrays(int, int, int);
  void set_arrays(int);
  int pack_exchange(int, double *);
  int unpack_exchange(int, double *);
  int pack_restart(int, double *);
  void unpack_restart(int, int);
  int size_restart(int);
  int maxsize_restart();
  double memory_usage();

 private:
  std::vector<std::vector<Slot> > current_;  // per local atom: the slots of the last step
  std::vector<std::vector<Slot> > next_;     // being written by this step's computation
  int pack(const std::vector<Slot> &slots, double *buf) const;
  int unpack(std::vector<Slot> &slots, const double *buf);
};

}

#endif
#endif
