// Explicit instantiations of the Lie group templates for the two scalar types dfo uses, so that
// every member compiles (and is warning-checked) once, whatever the callers use.
#include "dfo_core/lie.h"

namespace dfo {

template class SO3<double>;
template class SO3<float>;
template class SE3<double>;
template class SE3<float>;
template class Sim3<double>;
template class Sim3<float>;

}  // namespace dfo
