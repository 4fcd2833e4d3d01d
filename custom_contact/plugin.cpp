/* Registers the bilinear normal model with LIGGGHTS when this library is loaded (LD_PRELOAD).
 *
 * Written for dem-orchestrator. LIGGGHTS keeps contact models in factories filled by static
 * initialisers; this library adds the model's name to the contact-model factory and instantiates
 * the `gran` pair style and `wall/gran` variants listed in the generated style_contact_model.h.
 */
#include "fix_insert_stream.h"  // must precede granular_styles.h (missing include in the dev headers)
#include "granular_styles.h"

namespace
{
  struct RegisterBilinear
  {
    RegisterBilinear()
    {
      LIGGGHTS::ContactModels::Factory::instance().addNormalModel("bilinear", LIGGGHTS::ContactModels::BILINEAR);
    }
  };

  RegisterBilinear register_model_name;
  LAMMPS_NS::RegisterGranularStyles register_styles;
}
