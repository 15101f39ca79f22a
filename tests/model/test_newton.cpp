// The Newton core of the shooting solvers (model/src/newton.hpp) on small systems with known roots: both Jacobian
// reuse policies, the documented failure messages, and the reuse rule of a kept Jacobian.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "newton.hpp"  // internal

using namespace ctr;
using detail::JacobianReuse;

namespace {

// r(z) = (z0^2 + z1 - 3, z0 - z1^3 + 7), a root at (1, 2), with its Jacobian in closed form. `poison` makes the
// Jacobian NaN (no finite step).
class Quadratic final : public detail::NewtonSystem {
 public:
  void evaluate(const Eigen::VectorXd& z, bool jacobian) override {
    ++values;
    r_.resize(2);
    r_ << z[0] * z[0] + z[1] - 3.0, z[0] - z[1] * z[1] * z[1] + 7.0;
    if (!jacobian) return;
    ++jacobians;
    J_.resize(2, 2);
    J_ << 2.0 * z[0], 1.0, 1.0, -3.0 * z[1] * z[1];
    if (poison) J_.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  const Eigen::VectorXd& residual() const override { return r_; }
  Eigen::MatrixXd& jacobian() override { return J_; }
  double stability() const override { return J_.determinant(); }
  int values = 0, jacobians = 0;
  bool poison = false;

 private:
  Eigen::VectorXd r_;
  Eigen::MatrixXd J_;
};

detail::NewtonSettings settings(JacobianReuse reuse) {
  detail::NewtonSettings s;
  s.tolerance = 1e-12;
  s.reuse = reuse;
  return s;
}

}  // namespace

TEST(Newton, BothReusePoliciesConvergeToTheRoot) {
  for (JacobianReuse reuse : {JacobianReuse::Chord, JacobianReuse::Broyden}) {
    Quadratic S;
    detail::NewtonScratch w;
    detail::NewtonJacobian jac;
    Eigen::VectorXd z(2);
    z << 1.5, 1.5;
    int iterations = 0;
    double rn = 0.0;
    std::string why;
    ASSERT_TRUE(detail::newton(S, z, settings(reuse), w, jac, iterations, rn, why)) << why;
    EXPECT_NEAR(z[0], 1.0, 1e-11);
    EXPECT_NEAR(z[1], 2.0, 1e-11);
    EXPECT_LT(rn, 1e-12);
    EXPECT_GT(iterations, 0);
    // Away from a fold (|stability| > 0.25) a reused Jacobian is kept at the solution.
    if (reuse == JacobianReuse::Broyden) {
      EXPECT_LT(S.jacobians, S.values);
    }
  }
}

TEST(Newton, StartsFromACachedJacobian) {
  Quadratic S;
  Eigen::VectorXd z(2);
  z << 1.0, 2.0;
  S.evaluate(z, true);  // the exact Jacobian at the root, as a cache would hold it
  z << 1.01, 1.99;
  detail::NewtonScratch w;
  detail::NewtonJacobian jac;
  jac.from_cache = true;
  int iterations = 0;
  double rn = 0.0;
  std::string why;
  S.jacobians = 0;
  ASSERT_TRUE(detail::newton(S, z, settings(JacobianReuse::Broyden), w, jac, iterations, rn, why)) << why;
  EXPECT_EQ(S.jacobians, 0);  // Broyden updates only
  EXPECT_FALSE(jac.exact);
  EXPECT_GT(jac.updates, 0);
}

TEST(Newton, FailuresSayWhy) {
  detail::NewtonScratch w;
  int iterations = 0;
  double rn = 0.0;
  std::string why;
  {
    Quadratic S;
    detail::NewtonJacobian jac;
    Eigen::VectorXd z(2);
    z << 3.0, -2.0;
    detail::NewtonSettings s = settings(JacobianReuse::Chord);
    s.max_iterations = 1;
    EXPECT_FALSE(detail::newton(S, z, s, w, jac, iterations, rn, why));
    EXPECT_EQ(why.rfind("no convergence in 1 Newton iterations (residual ", 0), 0u) << why;
    EXPECT_GT(rn, 1e-12);
  }
  {
    Quadratic S;
    S.poison = true;
    detail::NewtonJacobian jac;
    Eigen::VectorXd z(2);
    z << 3.0, -2.0;
    EXPECT_FALSE(detail::newton(S, z, settings(JacobianReuse::Chord), w, jac, iterations, rn, why));
    EXPECT_EQ(why, "singular Jacobian");
  }
  {
    Quadratic S;
    detail::NewtonJacobian jac;
    Eigen::VectorXd z(2);
    z << std::numeric_limits<double>::quiet_NaN(), 1.0;
    EXPECT_FALSE(detail::newton(S, z, settings(JacobianReuse::Broyden), w, jac, iterations, rn, why));
    EXPECT_EQ(why, "non-finite residual");
  }
}

TEST(Newton, StepCapLimitsTheCappedUnknowns) {
  Quadratic S;
  detail::NewtonScratch w;
  detail::NewtonJacobian jac;
  Eigen::VectorXd z(2);
  z << 1.5, 1.5;
  detail::NewtonSettings s = settings(JacobianReuse::Chord);
  s.max_iterations = 1;
  s.step_cap = 1e-3;
  s.capped = 1;
  int iterations = 0;
  double rn = 0.0;
  std::string why;
  detail::newton(S, z, s, w, jac, iterations, rn, why);
  EXPECT_LE(std::abs(z[0] - 1.5), 1e-3 * (1 + 1e-12));
}

TEST(Newton, OneReuseRuleForKeptJacobians) {
  detail::JacobianCache C;
  Eigen::VectorXd q(4), model(3), z(2);
  q << 0.1, 0.2, -0.5, -1.0;  // history key: rotations (rad), translations x 50
  model << 1.0, 2.0, 3.0;
  z << 4.0, -1.0;
  EXPECT_FALSE(C.usable(q, model, z));  // empty
  C.store(Eigen::MatrixXd::Identity(2, 2), q, model, z, 1.0, 0);
  EXPECT_TRUE(C.usable(q, model, z));
  Eigen::VectorXd q2 = q;
  q2[0] += 0.099;
  EXPECT_TRUE(C.usable(q2, model, z));
  q2[0] += 0.002;  // 0.101 rad away
  EXPECT_FALSE(C.usable(q2, model, z));
  Eigen::VectorXd m2 = model;
  m2[1] = 2.0000001;  // another robot
  EXPECT_FALSE(C.usable(q, m2, z));
  Eigen::VectorXd z2 = z;
  z2[0] += 0.49;  // within 0.1 (1 + 4)
  EXPECT_TRUE(C.usable(q, model, z2));
  z2[0] += 0.02;
  EXPECT_FALSE(C.usable(q, model, z2));
  EXPECT_FALSE(C.usable(q, model, Eigen::VectorXd::Zero(3)));  // another number of unknowns
}
