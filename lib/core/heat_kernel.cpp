// The default heat time t = c_t h^(2/3) l^(4/3), the same for every dimension.
#include "digilap/core/heat_kernel.hpp"

#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace digilap {

namespace {
void check_positive(const char* what, double v) { require_positive(std::string("heat_laplacian: ") + what, v); }
}  // namespace

double heat_time(double h, const HeatLaplacianOptions& options, double measured_length_scale) {
  double t = options.t;
  if (t != 0) {
    check_positive("t", t);
  } else {
    check_positive("c_t", options.c_t);
    double l = options.length_scale;
    if (l != 0) check_positive("length_scale", l);
    else l = measured_length_scale;
    if (!(l > 0 && std::isfinite(l)))
      throw Error("heat_laplacian: no length scale for the default heat time c_t h^(2/3) l^(4/3): the measures do "
                  "not carry one (they come from ii_normals or exact_normals); give t or length_scale");
    t = options.c_t * std::pow(h, 2.0 / 3.0) * std::pow(l, 4.0 / 3.0);
  }
  if (!std::isfinite(t)) {  // c_t h^(2/3) l^(4/3) overflows for an extreme h or l
    std::ostringstream msg;
    msg << "heat_laplacian: the default heat time c_t h^(2/3) l^(4/3) is not finite (h = " << h << "): give t, or an h in a usable range";
    throw Error(msg.str());
  }
  // The kernel's prefactor 1 / (t sqrt(4 pi t)) must be a number (t above about 1e-206).
  if (!std::isfinite(1.0 / (t * std::sqrt(4.0 * kPi * t)))) {
    std::ostringstream msg;
    msg << "heat_laplacian: the heat time t = " << t << " is too small: the kernel's prefactor 1 / (t sqrt(4 pi t)) overflows";
    throw Error(msg.str());
  }
  return t;
}

}  // namespace digilap
