/* Per-atom contact history of rounded boxes: see fix_roundedbox_history.h. Written for dem-orchestrator. */
#include "fix_roundedbox_history.h"

#include <algorithm>
#include "atom.h"
#include "comm.h"
#include "error.h"

using namespace LAMMPS_NS;

FixRoundedBoxHistory::FixRoundedBoxHistory(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg)
{
  restart_peratom = 1;
  create_attribute = 1;
  grow_arrays(atom->nmax);
  atom->add_callback(0);  // grow, copy, exchange
  atom->add_callback(1);  // restart
  // an atom leaving for another process takes its slots: make room for the most it may have
  comm->maxexchange_fix = std::max(comm->maxexchange_fix, 1 + MAX_SLOTS * SLOT_DOUBLES);
}

FixRoundedBoxHistory::~FixRoundedBoxHistory()
{
  atom->delete_callback(id, 0);
  atom->delete_callback(id, 1);
}

void FixRoundedBoxHistory::begin(int nlocal)
{
  if (static_cast<int>(next_.size()) < nlocal) next_.resize(nlocal);
  for (int i = 0; i < nlocal; i++) next_[i].clear();
}

namespace {
// restart files and exchanges keep the slots sorted by (partner, key)
bool slotBefore(const FixRoundedBoxHistory::Slot &a, const FixRoundedBoxHistory::Slot &b)
{
  return a.partner < b.partner || (a.partner == b.partner && a.key < b.key);
}
}

/* Slots are looked up by a walk (an atom has a few dozen), so no sort is needed between steps. An
 * atom's slots with one partner atom lie together, in increasing key order (pair roundedbox stores a
 * pair's sub-contacts in one go, in key order): the walk stops at the first run. */
void FixRoundedBoxHistory::partner_slots(int i, double partner, const Slot *&first, const Slot *&last) const
{
  const std::vector<Slot> &slots = current_[i];
  const Slot *begin = slots.data(), *end = begin + slots.size();
  first = begin;
  while (first != end && first->partner != partner) first++;
  last = first;
  while (last != end && last->partner == partner) last++;
}

const RoundedBox::History *FixRoundedBoxHistory::find(int i, double partner, int key) const
{
  const std::vector<Slot> &slots = current_[i];
  for (size_t s = 0; s < slots.size(); s++)
    if (slots[s].partner == partner && slots[s].key == key) return &slots[s].history;
  return NULL;
}

void FixRoundedBoxHistory::store(int i, double partner, int key, const RoundedBox::History &history)
{
  if (static_cast<int>(next_[i].size()) >= MAX_SLOTS)
    error->one(FLERR, "A rounded box touches more than 256 sub-contacts: the contact history is full");
  Slot slot;
  slot.partner = partner;
  slot.key = key;
  slot.history = history;
  next_[i].push_back(slot);
}

void FixRoundedBoxHistory::commit(int nlocal)
{
  for (int i = 0; i < nlocal; i++) current_[i].swap(next_[i]);
}

void FixRoundedBoxHistory::grow_arrays(int nmax)
{
  if (static_cast<int>(current_.size()) < nmax) current_.resize(nmax);
}

void FixRoundedBoxHistory::copy_arrays(int i, int j, int)
{
  current_[j] = current_[i];
}

void FixRoundedBoxHistory::set_arrays(int i)
{
  current_[i].clear();
}

int FixRoundedBoxHistory::pack(const std::vector<Slot> &slots, double *buf) const
{
  int m = 0;
  buf[m++] = static_cast<double>(slots.size());
  for (size_t s = 0; s < slots.size(); s++) {
    buf[m++] = slots[s].partner;
    buf[m++] = static_cast<double>(slots[s].key);
    buf[m++] = slots[s].history.fn;
    buf[m++] = slots[s].history.overlap;
    for (int k = 0; k < 3; k++) buf[m++] = slots[s].history.ft[k];
  }
  return m;
}

int FixRoundedBoxHistory::unpack(std::vector<Slot> &slots, const double *buf)
{
  int m = 0;
  const int count = static_cast<int>(buf[m++]);
  slots.resize(count);
  for (int s = 0; s < count; s++) {
    slots[s].partner = buf[m++];
    slots[s].key = static_cast<int>(buf[m++]);
    slots[s].history.fn = buf[m++];
    slots[s].history.overlap = buf[m++];
    for (int k = 0; k < 3; k++) slots[s].history.ft[k] = buf[m++];
  }
  std::sort(slots.begin(), slots.end(), slotBefore);
  return m;
}

int FixRoundedBoxHistory::pack_exchange(int i, double *buf)
{
  return pack(current_[i], buf);
}

int FixRoundedBoxHistory::unpack_exchange(int nlocal, double *buf)
{
  grow_arrays(nlocal + 1);
  return unpack(current_[nlocal], buf);
}

int FixRoundedBoxHistory::pack_restart(int i, double *buf)
{
  // the first value is this fix's size in the atom's extra values (LAMMPS' convention)
  const int m = pack(current_[i], buf + 1);
  buf[0] = m + 1;
  return m + 1;
}

void FixRoundedBoxHistory::unpack_restart(int nlocal, int nth)
{
  double **extra = atom->extra;
  int m = 0;
  for (int i = 0; i < nth; i++) m += static_cast<int>(extra[nlocal][m]);
  grow_arrays(nlocal + 1);
  unpack(current_[nlocal], &extra[nlocal][m + 1]);
}

int FixRoundedBoxHistory::size_restart(int nlocal)
{
  return 2 + SLOT_DOUBLES * static_cast<int>(current_[nlocal].size());
}

int FixRoundedBoxHistory::maxsize_restart()
{
  int most = 0, most_all = 0;
  for (int i = 0; i < atom->nlocal; i++) most = std::max(most, static_cast<int>(current_[i].size()));
  MPI_Allreduce(&most, &most_all, 1, MPI_INT, MPI_MAX, world);
  return 2 + SLOT_DOUBLES * most_all;
}

double FixRoundedBoxHistory::memory_usage()
{
  double bytes = 0.0;
  for (size_t i = 0; i < current_.size(); i++) bytes += current_[i].capacity() * sizeof(Slot);
  for (size_t i = 0; i < next_.size(); i++) bytes += next_[i].capacity() * sizeof(Slot);
  return bytes;
}
