// Rigid registration + tip offset between model and sensor frames (closed form, alternated).
#include "ctr/diagnosis/registration.hpp"

#include <Eigen/SVD>
#include <cmath>

namespace ctr::diagnosis {

namespace {
bool finiteRow(const Eigen::MatrixXd& M, Eigen::Index k) {
  return M.cols() == 3 && M.row(k).allFinite();
}
}  // namespace

Registration fitRegistration(const Eigen::MatrixXd& P, const Eigen::MatrixXd& T, const Eigen::MatrixXd& MP,
                             const Eigen::MatrixXd& MT, const std::vector<char>& use, const RegistrationOptions& o) {
  Registration reg;
  const Eigen::Index rows = P.rows();
  const bool hasP = MP.cols() == 3, hasT = MT.cols() == 3;
  if (!hasP && !hasT) return reg;
  // Rows flagged in `use` whose prediction exists (a row the model could not evaluate has NaN outputs).
  auto used = [&](Eigen::Index k) {
    return k < static_cast<Eigen::Index>(use.size()) && use[static_cast<std::size_t>(k)] && P.row(k).allFinite() &&
           T.row(k).allFinite();
  };
  const int iters = (hasP && o.estimate_offset) ? o.iterations : 1;
  double d = 0.0;
  for (int it = 0; it < iters; ++it) {
    // Rotation and translation for the current offset (weighted Kabsch with points and directions).
    Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
    double wsum = 0.0;
    if (hasP) {
      for (Eigen::Index k = 0; k < rows; ++k) {
        if (!used(k) || !finiteRow(MP, k)) continue;
        ca += P.row(k).transpose() + d * T.row(k).transpose();
        cb += MP.row(k).transpose();
        wsum += 1.0;
      }
      if (wsum > 0) {
        ca /= wsum;
        cb /= wsum;
      }
    }
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    if (hasP && wsum > 0)
      for (Eigen::Index k = 0; k < rows; ++k) {
        if (!used(k) || !finiteRow(MP, k)) continue;
        const Eigen::Vector3d a = P.row(k).transpose() + d * T.row(k).transpose() - ca;
        const Eigen::Vector3d b = MP.row(k).transpose() - cb;
        H += o.position_weight * a * b.transpose();
      }
    if (hasT)
      for (Eigen::Index k = 0; k < rows; ++k) {
        if (!used(k) || !finiteRow(MT, k)) continue;
        H += o.tangent_weight * T.row(k).transpose() * MT.row(k);
      }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
    reg.rotation = svd.matrixV() * D * svd.matrixU().transpose();
    reg.translation = hasP && wsum > 0 ? Eigen::Vector3d(cb - reg.rotation * ca) : Eigen::Vector3d::Zero();
    reg.tip_offset = d;
    if (!(hasP && o.estimate_offset)) break;
    // Offset along the tangent for this rotation (linear least squares with the translation re-centred).
    Eigen::Vector3d mt = Eigen::Vector3d::Zero(), mr = Eigen::Vector3d::Zero();
    for (Eigen::Index k = 0; k < rows; ++k) {
      if (!used(k) || !finiteRow(MP, k)) continue;
      mt += reg.rotation * T.row(k).transpose();
      mr += MP.row(k).transpose() - reg.rotation * P.row(k).transpose();
    }
    mt /= wsum;
    mr /= wsum;
    double num = 0, den = 0;
    for (Eigen::Index k = 0; k < rows; ++k) {
      if (!used(k) || !finiteRow(MP, k)) continue;
      const Eigen::Vector3d rt = reg.rotation * T.row(k).transpose() - mt;
      const Eigen::Vector3d rr = MP.row(k).transpose() - reg.rotation * P.row(k).transpose() - mr;
      num += rt.dot(rr);
      den += rt.squaredNorm();
    }
    const double dn = den > 1e-12 ? num / den : 0.0;
    if (std::abs(dn - d) < 1e-9) {
      d = dn;
      reg.tip_offset = d;
      reg.translation = mr - d * mt;
      break;
    }
    d = dn;
  }
  return reg;
}

void applyRegistration(const Registration& reg, Eigen::MatrixXd& P, Eigen::MatrixXd& T) {
  for (Eigen::Index k = 0; k < P.rows(); ++k) {
    const Eigen::Vector3d p = P.row(k).transpose(), t = T.row(k).transpose();
    P.row(k) = reg.mapPosition(p, t).transpose();
    T.row(k) = reg.mapTangent(t).transpose();
  }
}

}  // namespace ctr::diagnosis
