#include "mapdelta/vio/marginalization.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <map>

#include "mapdelta/common/lie.hpp"
#include "mapdelta/vio/factors.hpp"

namespace mapdelta::vio {
namespace {

// Dropped states' Hessian: directions with curvature at or below this are unobserved (the
// window's gauge, a landmark seen once) and stay out of the inverse.
constexpr EigenvalueCutoff kDroppedStatesCutoff{1e-8, 0};

}  // namespace

void Marginalizer::AddResidualBlock(ceres::CostFunction* cost, const ceres::LossFunction* loss,
                                    std::vector<double*> params) {
  blocks_.push_back({std::unique_ptr<ceres::CostFunction>(cost), loss, std::move(params)});
}

Marginalizer::TangentLayout Marginalizer::LayOut() {
  TangentLayout layout;
  for (const auto& b : blocks_) {
    const auto& sizes = b.cost->parameter_block_sizes();
    for (size_t k = 0; k < b.params.size(); ++k) layout.ambient_size[b.params[k]] = sizes[k];
  }
  int next = 0;
  for (const auto& [block, size] : layout.ambient_size) {
    if (dropped_.count(block)) {
      layout.offset[block] = next;
      next += TangentSizeOf(size);
    }
  }
  layout.dropped = next;
  kept_.clear();
  kept_sizes_.clear();
  x0_.clear();
  for (const auto& [block, size] : layout.ambient_size) {
    if (dropped_.count(block)) continue;
    layout.offset[block] = next;
    next += TangentSizeOf(size);
    kept_.push_back(const_cast<double*>(block));
    kept_sizes_.push_back(size);
    x0_.push_back(Eigen::Map<const Eigen::VectorXd>(block, size));
  }
  layout.total = next;
  return layout;
}

// Robustified by the loss's first derivative (iteratively reweighted least squares weight).
void Marginalizer::Linearize(const TangentLayout& layout, Eigen::MatrixXd* H,
                             Eigen::VectorXd* g) const {
  *H = Eigen::MatrixXd::Zero(layout.total, layout.total);
  *g = Eigen::VectorXd::Zero(layout.total);
  for (const auto& b : blocks_) {
    const auto& sizes = b.cost->parameter_block_sizes();
    const int nr = b.cost->num_residuals();
    Eigen::VectorXd r(nr);
    std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Ja(
        b.params.size());
    std::vector<double*> jac_ptrs(b.params.size());
    for (size_t k = 0; k < b.params.size(); ++k) {
      Ja[k].resize(nr, sizes[k]);
      jac_ptrs[k] = Ja[k].data();
    }
    if (!b.cost->Evaluate(b.params.data(), r.data(), jac_ptrs.data())) continue;
    double w = 1.0;
    if (b.loss) {
      double rho[3];
      b.loss->Evaluate(r.squaredNorm(), rho);
      w = std::sqrt(std::max(rho[1], 0.0));
    }
    r *= w;
    std::vector<Eigen::MatrixXd> Jt(b.params.size());
    for (size_t k = 0; k < b.params.size(); ++k) {
      Jt[k] = w * ToTangentJacobian(b.params[k], sizes[k], Ja[k]);
    }
    for (size_t a = 0; a < b.params.size(); ++a) {
      const int oa = layout.offset.at(b.params[a]);
      g->segment(oa, Jt[a].cols()) += Jt[a].transpose() * r;
      for (size_t c = 0; c < b.params.size(); ++c) {
        const int oc = layout.offset.at(b.params[c]);
        H->block(oa, oc, Jt[a].cols(), Jt[c].cols()) += Jt[a].transpose() * Jt[c];
      }
    }
  }
}

// Dropped blocks of size 1 (landmark inverse depths, which share no factor with each other)
// form a diagonal block: eliminated first in O(n^2) each, then the remaining dropped states
// densely.
void Marginalizer::ReduceOntoKept(const TangentLayout& layout, Eigen::MatrixXd H,
                                  Eigen::VectorXd g) {
  const int n = layout.total, m = layout.dropped;
  std::vector<int> points, states;
  for (const auto& [block, size] : layout.ambient_size) {
    if (!dropped_.count(block)) continue;
    const int offset = layout.offset.at(block);
    (size == 1 ? points : states).push_back(offset);
    if (size != 1) {
      for (int d = 1; d < TangentSizeOf(size); ++d) states.push_back(offset + d);
    }
  }
  for (int p : points) {
    const double hpp = H(p, p);
    if (!(hpp > 1e-12)) continue;
    // A point couples to a few poses only: update just the rows/columns it touches.
    std::vector<int> nz;
    for (int i = 0; i < n; ++i) {
      if (H(i, p) != 0.0) nz.push_back(i);
    }
    std::vector<double> col(nz.size());
    for (size_t i = 0; i < nz.size(); ++i) col[i] = H(nz[i], p);  // copy: updated below
    const double gp = g[p];
    for (size_t i = 0; i < nz.size(); ++i) {
      const double ha = col[i] / hpp;
      g[nz[i]] -= ha * gp;
      for (size_t j = 0; j < nz.size(); ++j) H(nz[i], nz[j]) -= ha * col[j];
    }
  }
  const int k = n - m;
  const int ms = static_cast<int>(states.size());
  if (ms == 0) {
    H_ = H.bottomRightCorner(k, k);
    b_ = g.tail(k);
    return;
  }
  Eigen::MatrixXd Hss(ms, ms), Hks(k, ms);
  Eigen::VectorXd gs(ms);
  for (int a = 0; a < ms; ++a) {
    gs[a] = g[states[a]];
    Hks.col(a) = H.block(m, states[a], k, 1);
    for (int c = 0; c < ms; ++c) Hss(a, c) = H(states[a], states[c]);
  }
  const Eigen::MatrixXd Hss_inv = PseudoInverse(Hss, kDroppedStatesCutoff);
  H_ = H.bottomRightCorner(k, k) - Hks * Hss_inv * Hks.transpose();
  b_ = g.tail(k) - Hks * Hss_inv * gs;
}

bool Marginalizer::Marginalize() {
  // 1. Order the tangent coordinates: dropped blocks first, then kept ones.
  const TangentLayout layout = LayOut();
  if (kept_.empty()) return false;
  // 2. The Gauss-Newton system of every block at the current estimate.
  Eigen::MatrixXd H;
  Eigen::VectorXd g;
  Linearize(layout, &H, &g);
  // 3. Schur complement onto the kept coordinates, factored as the prior's J and r.
  ReduceOntoKept(layout, std::move(H), std::move(g));
  Factor();
  blocks_.clear();
  return true;
}

void Marginalizer::RemoveDirections(const Eigen::MatrixXd& directions) {
  const Eigen::MatrixXd HN = H_ * directions;
  const Eigen::MatrixXd NHN = directions.transpose() * HN;
  // Directions the prior already knows nothing about stay out of the inverse.
  const Eigen::MatrixXd NHN_inv = PseudoInverse(NHN, {1e-12 * std::max(1.0, NHN.trace()), 0});
  b_ -= HN * (NHN_inv * (directions.transpose() * b_));
  H_ -= HN * NHN_inv * HN.transpose();
  Factor();
}

void Marginalizer::Factor() {
  // Factor H* = J^T J with J = S^1/2 V^T, and r = S^-1/2 V^T b*.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (H_ + H_.transpose()));
  const Eigen::ArrayXd s = es.eigenvalues().array();
  const Eigen::ArrayXd keep = (s > 1e-8).cast<double>();
  const Eigen::VectorXd s_sqrt = (s * keep).sqrt();
  const Eigen::VectorXd s_inv_sqrt = (keep > 0).select(s.max(1e-300).sqrt().inverse(), 0.0);
  J_ = s_sqrt.asDiagonal() * es.eigenvectors().transpose();
  r_ = s_inv_sqrt.asDiagonal() * es.eigenvectors().transpose() * b_;
}

MarginalizationFactor::MarginalizationFactor(std::shared_ptr<const Marginalizer> info)
    : info_(std::move(info)) {
  for (int size : info_->kept_sizes()) mutable_parameter_block_sizes()->push_back(size);
  set_num_residuals(static_cast<int>(info_->r().size()));
}

bool MarginalizationFactor::Evaluate(double const* const* parameters, double* residuals,
                                     double** jacobians) const {
  const auto& sizes = info_->kept_sizes();
  const int n = static_cast<int>(info_->r().size());
  Eigen::VectorXd dx(n);
  std::vector<int> offsets;
  int o = 0;
  for (size_t k = 0; k < sizes.size(); ++k) {
    offsets.push_back(o);
    const int t = TangentSizeOf(sizes[k]);
    dx.segment(o, t) =
        TangentMinus(parameters[k], info_->linearization_points()[k].data(), sizes[k]);
    o += t;
  }
  Eigen::Map<Eigen::VectorXd>(residuals, n) = info_->r() + info_->J() * dx;
  if (!jacobians) return true;
  for (size_t k = 0; k < sizes.size(); ++k) {
    if (!jacobians[k]) continue;
    const int t = TangentSizeOf(sizes[k]);
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Jk(
        jacobians[k], n, sizes[k]);
    const Eigen::MatrixXd Jt = info_->J().middleCols(offsets[k], t);
    if (sizes[k] != 7) {
      Jk = Jt;
      continue;
    }
    // d(tangent minus)/d(ambient): position is identity; rotation Log(q0^-1 q) has tangent
    // Jacobian Jr^-1(dtheta), mapped to ambient by the pseudo-inverse of the Plus Jacobian.
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> M;
    PoseManifold().MinusJacobian(parameters[k], M.data());
    M.bottomRows<3>() = RightJacobianInvSO3(dx.segment<3>(offsets[k] + 3)) * M.bottomRows<3>();
    Jk = Jt * M;
  }
  return true;
}

}  // namespace mapdelta::vio
