/* Registers the bilinear normal model with LIGGGHTS when this library is loaded (LD_PRELOAD).
 *
 * Written for dem-orchestrator. LIGGGHTS keeps contact models in factories: the model's name goes
 * into the contact-model factory, and the `gran` pair style and `wall/gran` variants for
 * (bilinear, history | no_history) go into the pair and wall factories. Built with hidden
 * visibility, so none of the engine's own (inline) registration code is replaced by ours.
 */
#include "fix_insert_stream.h"  // must precede granular_styles.h (missing include in the dev headers)
#include "granular_styles.h"

namespace
{
  using namespace LIGGGHTS;
  using namespace LIGGGHTS::ContactModels;

  template<typename Style>
  PairStyles::IGranularPairStyle * make_pair(LAMMPS_NS::LAMMPS * lmp, LAMMPS_NS::PairGran * parent, const int64_t hash)
  {
    return new PairStyles::Granular<ContactModel<Style> >(lmp, parent, hash);
  }

  template<typename Style>
  Walls::IGranularWall * make_wall(LAMMPS_NS::LAMMPS * lmp, LAMMPS_NS::FixWallGran * parent, const int64_t hash)
  {
    return new Walls::Granular<ContactModel<Style> >(lmp, parent, hash);
  }

  template<int TANGENTIAL>
  void register_variant()
  {
    typedef GranStyle<BILINEAR, TANGENTIAL, COHESION_OFF, ROLLING_OFF, SURFACE_DEFAULT> Style;
    PairStyles::Factory::instance().addStyle("gran", Style::HASHCODE, &make_pair<Style>);
    Walls::Factory::instance().addStyle("gran", Style::HASHCODE, &make_wall<Style>);
  }

  struct RegisterBilinear
  {
    RegisterBilinear()
    {
      Factory::instance().addNormalModel("bilinear", BILINEAR);
      register_variant<TANGENTIAL_HISTORY>();
      register_variant<TANGENTIAL_NO_HISTORY>();
    }
  };

  RegisterBilinear register_bilinear;
}
