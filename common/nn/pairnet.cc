#include "common/nn/pairnet.h"

#include <cassert>
#include <cmath>

namespace coins::nn {

Status PairNetOptions::Validate() const {
  if (source_dim < 0 || instance_dim <= 0)
    return Errorf("pairnet: source_dim {} must be >= 0 and instance_dim {} > 0", source_dim, instance_dim);
  if (max_instances <= 0) return Errorf("pairnet: max_instances {} must be > 0", max_instances);
  for (size_t k = 0; k < relative.size(); ++k) {
    const RelativeFeature& r = relative[k];
    if (r.source < 0 || r.source >= source_dim || r.instance < 0 || r.instance >= instance_dim)
      return Errorf("pairnet: relative feature {} pairs source row {} with instance row {} (rows: {} and {})", k,
                    r.source, r.instance, source_dim, instance_dim);
    if (!std::isfinite(r.scale) || !std::isfinite(r.shift))
      return Errorf("pairnet: relative feature {} has scale {} and shift {} (finite values only)", k, r.scale, r.shift);
  }
  if (point_sizes.empty()) return Errorf("pairnet: point_sizes is empty");
  for (int s : point_sizes)
    if (s <= 0) return Errorf("pairnet: point size {} must be positive", s);
  for (int s : head_sizes)
    if (s <= 0) return Errorf("pairnet: head size {} must be positive", s);
  if (output_dim <= 0) return Errorf("pairnet: output_dim {} must be positive", output_dim);
  return Status::Ok();
}

std::vector<RelativeFeature> LeadingRelative(int count) {
  std::vector<RelativeFeature> r;
  for (int i = 0; i < count; ++i) r.push_back({i, i, 1.0f, 0.0f});
  return r;
}

PairNet::PairNet(PairNetOptions options, uint64_t seed) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  std::mt19937_64 rng(seed);
  // same block order and init as an Mlp of sizes {point_in, point_sizes..., output_dim}
  std::vector<int> sizes = {options_.point_input_dim()};
  sizes.insert(sizes.end(), options_.point_sizes.begin(), options_.point_sizes.end());
  sizes.insert(sizes.end(), options_.head_sizes.begin(), options_.head_sizes.end());
  sizes.push_back(options_.output_dim);
  for (size_t l = 0; l + 1 < sizes.size(); ++l) {
    int w = params_.Add(fmt::format("layer{}.w", l), sizes[l + 1], sizes[l]);
    int b = params_.Add(fmt::format("layer{}.b", l), sizes[l + 1], 1);
    float scale = 1.0f / std::sqrt(float(sizes[l]));
    InitUniform(params_.Value(w), scale, &rng);
    InitUniform(params_.Value(b), scale, &rng);
  }
  acts_.resize(num_point_layers() + 1);
  deltas_.resize(num_point_layers());
  head_acts_.resize(options_.head_sizes.size());
  head_deltas_.resize(options_.head_sizes.size());
}

const Eigen::MatrixXf& PairNet::Forward(const Eigen::Ref<const Eigen::MatrixXf>& source,
                                        const Eigen::Ref<const Eigen::MatrixXf>& instances,
                                        const Eigen::Ref<const Eigen::MatrixXf>& mask) {
  const int n = options_.max_instances, ds = options_.source_dim, di = options_.instance_dim;
  const int k = int(options_.relative.size());
  const Eigen::Index batch = source.cols();
  assert(source.rows() == ds && instances.rows() == n * di && mask.rows() == n);
  assert(instances.cols() == batch && mask.cols() == batch);

  // build the points: column b * N + i = [s_a; s_b,i; relative features]
  Eigen::MatrixXf& points = acts_[0];
  points.resize(options_.point_input_dim(), n * batch);
  present_.resize(size_t(n) * batch);
  for (Eigen::Index b = 0; b < batch; ++b) {
    for (int i = 0; i < n; ++i) {
      const Eigen::Index c = b * n + i;
      present_[c] = mask(i, b) > 0.5f;
      if (ds > 0) points.col(c).head(ds) = source.col(b);
      points.col(c).segment(ds, di) = instances.col(b).segment(i * di, di);
      for (int r = 0; r < k; ++r) {
        const RelativeFeature& f = options_.relative[size_t(r)];
        points(ds + di + r, c) = f.scale * source(f.source, b) + f.shift - instances(i * di + f.instance, b);
      }
    }
  }

  // shared per-point MLP
  for (int l = 0; l < num_point_layers(); ++l) {
    auto w = params_.Value(2 * l);
    auto bias = params_.Value(2 * l + 1);
    Eigen::MatrixXf& out = acts_[l + 1];
    out.resize(w.rows(), points.cols());
    out.noalias() = w * acts_[l];
    out.colwise() += bias.col(0);
    ApplyActivation(options_.hidden, out);
  }

  // masked max-pool over instances, remembering the winner per feature
  const Eigen::MatrixXf& h = acts_.back();
  const Eigen::Index f = h.rows();
  pooled_.setZero(f, batch);
  argmax_.setConstant(f, batch, -1);
  for (Eigen::Index b = 0; b < batch; ++b) {
    bool any = false;
    for (int i = 0; i < n; ++i) {
      const Eigen::Index c = b * n + i;
      if (!present_[c]) continue;
      if (!any) {
        pooled_.col(b) = h.col(c);
        argmax_.col(b).setConstant(i);
        any = true;
        continue;
      }
      auto greater = h.col(c).array() > pooled_.col(b).array();
      argmax_.col(b) = greater.select(Eigen::ArrayXi::Constant(f, i), argmax_.col(b));
      pooled_.col(b) = pooled_.col(b).cwiseMax(h.col(c));
    }
  }

  // dense layers after the pool: the head's hidden layers, then the output
  const int last = num_point_layers(), dense = num_dense_layers();
  const Eigen::MatrixXf* in = &pooled_;
  for (int j = 0; j < dense; ++j) {
    auto w = params_.Value(2 * (last + j));
    auto bias = params_.Value(2 * (last + j) + 1);
    const bool output = j + 1 == dense;
    Eigen::MatrixXf& o = output ? out_ : head_acts_[size_t(j)];
    o.resize(w.rows(), batch);
    o.noalias() = w * *in;
    o.colwise() += bias.col(0);
    ApplyActivation(output ? options_.output : options_.hidden, o);
    in = &o;
  }
  return out_;
}

const Eigen::MatrixXf& PairNet::Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool source_grad,
                                         bool accumulate) {
  const int n = options_.max_instances;
  const Eigen::Index batch = out_.cols();
  assert(dout.rows() == out_.rows() && dout.cols() == batch);
  const int last = num_point_layers();

  // dense layers after the pool, from the output down to the pooled features' gradient
  out_delta_ = dout;
  ActivationBackward(options_.output, out_, out_delta_);
  const Eigen::MatrixXf* delta = &out_delta_;
  for (int j = num_dense_layers() - 1; j >= 0; --j) {
    const Eigen::MatrixXf& in = j == 0 ? pooled_ : head_acts_[size_t(j) - 1];
    auto gw = params_.Grad(2 * (last + j));
    auto gb = params_.Grad(2 * (last + j) + 1);
    if (accumulate) {
      gw.noalias() += *delta * in.transpose();
      gb.col(0) += delta->rowwise().sum();
    } else {
      gw.noalias() = *delta * in.transpose();
      gb.col(0) = delta->rowwise().sum();
    }
    Eigen::MatrixXf& below = j == 0 ? pooled_grad_ : head_deltas_[size_t(j) - 1];
    below.resize(in.rows(), batch);
    below.noalias() = params_.Value(2 * (last + j)).transpose() * *delta;
    if (j > 0) ActivationBackward(options_.hidden, in, below);
    delta = &below;
  }

  // route the pooled gradient to the winning instance of each feature
  Eigen::MatrixXf& dh = deltas_[last - 1];
  dh.setZero(acts_.back().rows(), n * batch);
  for (Eigen::Index b = 0; b < batch; ++b)
    for (Eigen::Index r = 0; r < pooled_.rows(); ++r) {
      const int i = argmax_(r, b);
      if (i >= 0) dh(r, b * n + i) = pooled_grad_(r, b);
    }
  ActivationBackward(options_.hidden, acts_.back(), dh);

  // shared per-point MLP
  for (int l = last - 1; l >= 0; --l) {
    const Eigen::MatrixXf& delta = deltas_[l];
    auto w = params_.Value(2 * l);
    auto pw = params_.Grad(2 * l);
    auto pb = params_.Grad(2 * l + 1);
    if (accumulate) {
      pw.noalias() += delta * acts_[l].transpose();
      pb.col(0) += delta.rowwise().sum();
    } else {
      pw.noalias() = delta * acts_[l].transpose();
      pb.col(0) = delta.rowwise().sum();
    }
    if (l > 0) {
      deltas_[l - 1].resize(w.cols(), delta.cols());
      deltas_[l - 1].noalias() = w.transpose() * delta;
      ActivationBackward(options_.hidden, acts_[l], deltas_[l - 1]);
    }
  }
  if (!source_grad) return empty_;  // source_grad_ keeps its workspace for the next caller that asks
  SourceGrad();
  return source_grad_;
}

// every point holds s_a in its head and scaled source rows in the relative tail: both feed the
// source's gradient, summed over the instances (an absent one got no gradient from the pool)
void PairNet::SourceGrad() {
  const int n = options_.max_instances, ds = options_.source_dim, di = options_.instance_dim;
  const int k = int(options_.relative.size());
  const Eigen::Index batch = out_.cols();
  point_grad_.resize(acts_[0].rows(), acts_[0].cols());
  point_grad_.noalias() = params_.Value(0).transpose() * deltas_[0];
  source_grad_.setZero(ds, batch);
  for (Eigen::Index b = 0; b < batch; ++b)
    for (int i = 0; i < n; ++i) {
      const Eigen::Index c = b * n + i;
      if (ds > 0) source_grad_.col(b) += point_grad_.col(c).head(ds);
      for (int r = 0; r < k; ++r) {
        const RelativeFeature& f = options_.relative[size_t(r)];
        source_grad_(f.source, b) += f.scale * point_grad_(ds + di + r, c);
      }
    }
}

int64_t PairNet::MacsPerSample() const {
  int64_t macs = 0;
  int in = options_.point_input_dim();
  for (int s : options_.point_sizes) {
    macs += int64_t(in) * s * options_.max_instances;
    in = s;
  }
  for (int s : options_.head_sizes) {
    macs += int64_t(in) * s;
    in = s;
  }
  return macs + int64_t(in) * options_.output_dim;
}

}  // namespace coins::nn
