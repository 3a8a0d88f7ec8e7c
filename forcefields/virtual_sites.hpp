#pragma once
// GROMACS's virtual sites (System::virtual_sites) as the force field's SiteConstruction. Each
// construction is written twice as a template on the number type: the site's offset from atom i,
// and its transpose Jacobian applied to a force. On Dual numbers with the atoms' motion u as the
// derivative part, the first gives the sites' tangent J u and the second the derivative of Jᵀ F
// along u, the constructions' own second derivative, exactly.
#include <vector>

#include "engine/box.hpp"
#include "engine/force_field.hpp"
#include "engine/system.hpp"

namespace vimd {

class VirtualSiteConstruction : public SiteConstruction {
 public:
  VirtualSiteConstruction(std::vector<VirtualSite> sites, const Box& box);
  void place(Coords& q) const override;
  void tangent(const Coords& q, Coords& u) const override;
  void spread(const Coords& q, Coords& f) const override;
  void spread_hessian(const Coords& q, const Coords& u, const Coords* site_forces, Coords& hv) const override;
  bool linear() const override { return linear_; }

 private:
  std::vector<VirtualSite> sites_;  // in construction order
  Box box_;
  bool linear_ = true;
};

}  // namespace vimd
