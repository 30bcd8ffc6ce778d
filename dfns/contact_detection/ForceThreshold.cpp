// ContactDetection/ForceThreshold: the 2019 approach (a threshold on the force's norm), kept to
// measure what the bias, the hysteresis and the torque add (docs/haptic-scanning.md).
#include "ContactDetection.gen.hpp"
#include "contact_geometry.hpp"

namespace cdff::dfn {

class ContactDetectionForceThreshold final : public ContactDetectionForceThresholdBase {
 protected:
  Status onProcess() override {
    const Wrench& w = *in.wrench;
    CDFF_RETURN_IF_ERROR(contact::checkSample(w, params_.force_range, params_.torque_range));
    const bool touching = w.force.norm() > params_.threshold && w.force.norm() > 0;
    out.in_contact.set(touching);
    if (!touching) return Status::ok();
    // The force taken as the surface's push along its normal.
    const Eigen::Vector3d n = w.force.normalized();
    const Eigen::Vector3d centre(params_.tip_centre[0], params_.tip_centre[1],
                                 params_.tip_centre[2]);
    out.contact.set(contact::contactCloud(centre - params_.tip_radius * n, n, w.force.norm(), w));
    return Status::ok();
  }
};

CDFF_REGISTER_DFI(ContactDetectionForceThreshold);

}  // namespace cdff::dfn
