#pragma once
// Marginalization by Schur complement (internal; pulls in Ceres).
// Residual blocks touching the dropped parameters are linearized at the current estimate;
// the Gauss-Newton system over [dropped | kept] tangent coordinates is reduced to the kept
// ones: H* = Hkk - Hkd Hdd^-1 Hdk, b* = bk - Hkd Hdd^-1 bd, and factored as H* = J^T J,
// b* = J^T r so that a prior residual r + J * (x - x0) reproduces it.
#include <ceres/ceres.h>

#include <Eigen/Core>
#include <map>
#include <memory>
#include <set>
#include <vector>

namespace mapdelta::vio {

class Marginalizer {
 public:
  // `cost` becomes owned; `loss` (may be null) is borrowed and must outlive Marginalize().
  void AddResidualBlock(ceres::CostFunction* cost, const ceres::LossFunction* loss,
                        std::vector<double*> blocks);
  // Parameter blocks to eliminate (others touched by the residuals are kept).
  void Drop(const double* block) { dropped_.insert(block); }
  // Builds the prior. Returns false if nothing is kept.
  bool Marginalize();
  // Removes what the prior says along the columns of `directions` (tangent directions of the
  // kept blocks at the linearization points, in the order of kept_blocks()): the Schur
  // complement with those directions as unknowns, H' = H - H N (N^T H N)^+ N^T H, and the
  // same for b. The prior then neither holds nor pulls the estimate along them. Call after
  // Marginalize().
  void RemoveDirections(const Eigen::MatrixXd& directions);

  // The result, valid after Marginalize().
  const std::vector<double*>& kept_blocks() const { return kept_; }
  const std::vector<int>& kept_sizes() const { return kept_sizes_; }  // ambient sizes
  const std::vector<Eigen::VectorXd>& linearization_points() const { return x0_; }
  const Eigen::MatrixXd& J() const { return J_; }
  const Eigen::VectorXd& r() const { return r_; }
  // The reduced Hessian / gradient (for tests and covariance extraction).
  const Eigen::MatrixXd& H() const { return H_; }
  const Eigen::VectorXd& b() const { return b_; }

 private:
  struct Block {
    std::unique_ptr<ceres::CostFunction> cost;
    const ceres::LossFunction* loss = nullptr;
    std::vector<double*> params;
  };
  // Tangent coordinates of every block: dropped ones first (dims [0, dropped)), then the
  // kept ones (dims [dropped, total)).
  struct TangentLayout {
    std::map<const double*, int> ambient_size, offset;
    int dropped = 0, total = 0;
  };
  TangentLayout LayOut();  // also sets kept_, kept_sizes_, x0_
  // H = J^T J and g = J^T r of every block at the current estimate, in the layout's order.
  void Linearize(const TangentLayout& layout, Eigen::MatrixXd* H, Eigen::VectorXd* g) const;
  // The Schur complement of the dropped coordinates: H_, b_ over the kept ones.
  void ReduceOntoKept(const TangentLayout& layout, Eigen::MatrixXd H, Eigen::VectorXd g);
  void Factor();  // H_, b_ -> J_, r_

  std::vector<Block> blocks_;
  std::set<const double*> dropped_;
  std::vector<double*> kept_;
  std::vector<int> kept_sizes_;
  std::vector<Eigen::VectorXd> x0_;
  Eigen::MatrixXd J_, H_;
  Eigen::VectorXd r_, b_;
};

// Prior residual r + J * (x (-) x0) over the kept blocks of a Marginalizer.
class MarginalizationFactor : public ceres::CostFunction {
 public:
  explicit MarginalizationFactor(std::shared_ptr<const Marginalizer> info);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::shared_ptr<const Marginalizer> info_;
};

}  // namespace mapdelta::vio
