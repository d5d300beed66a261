#include "common/nn/qnet.h"

#include <cassert>
#include <cmath>

namespace coins::nn {

namespace {

// the pair network of a split observation: the rows outside the instances are its source
PairNetOptions PairOptions(const QNetOptions& o) {
  const InstanceSplit& s = o.split;
  PairNetOptions p;
  p.source_dim = o.obs_dim - s.instances * s.instance_dim;
  p.instance_dim = s.instance_dim;
  p.max_instances = s.instances;
  p.point_sizes = o.hidden;
  p.head_sizes = s.head;
  p.output_dim = o.outputs;
  p.hidden = o.hidden_act;
  p.output = o.output_act;
  for (RelativeFeature r : s.relative) {  // observation rows -> rows of the pair-net's source
    if (r.source >= s.offset) r.source -= s.instances * s.instance_dim;
    p.relative.push_back(r);
  }
  return p;
}

}  // namespace

Status QNetOptions::Validate() const {
  if (obs_dim <= 0 || outputs <= 0) return Errorf("network: obs_dim {} and outputs {} must be > 0", obs_dim, outputs);
  if (hidden.empty()) return Errorf("network: at least one hidden layer");
  if (!split.enabled()) return Status::Ok();
  const InstanceSplit& s = split;
  if (s.instance_dim <= 0 || s.offset < 0 || s.offset + s.instances * s.instance_dim > obs_dim)
    return Errorf("network: {} instances of {} rows at row {} do not fit an observation of {}", s.instances,
                  s.instance_dim, s.offset, obs_dim);
  if (s.presence < -1 || s.presence >= s.instance_dim)
    return Errorf("network: presence row {} outside an instance of {} (-1: always present)", s.presence,
                  s.instance_dim);
  const int end = s.offset + s.instances * s.instance_dim;
  for (size_t k = 0; k < s.relative.size(); ++k) {
    const RelativeFeature& r = s.relative[k];
    if (r.source < 0 || r.source >= obs_dim || (r.source >= s.offset && r.source < end))
      return Errorf("network: relative feature {} reads observation row {}, not a row outside the instances", k,
                    r.source);
    if (r.instance < 0 || r.instance >= s.instance_dim)
      return Errorf("network: relative feature {} reads instance row {} of {}", k, r.instance, s.instance_dim);
  }
  return PairOptions(*this).Validate();  // the rest (finite scale and shift, layer sizes)
}

QNet::QNet(QNetOptions options, uint64_t seed) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  if (!options_.split.enabled()) {
    mlp_ =
        Mlp({LayerSizes(options_.obs_dim, options_.hidden, options_.outputs), options_.hidden_act, options_.output_act},
            seed);
    return;
  }
  pair_ = PairNet(PairOptions(options_), seed);
}

const Eigen::MatrixXf& QNet::Forward(const Eigen::Ref<const Eigen::MatrixXf>& obs) {
  if (!options_.split.enabled()) return mlp_.Forward(obs);
  const InstanceSplit& s = options_.split;
  const Eigen::Index B = obs.cols(), rows = Eigen::Index(s.instances) * s.instance_dim,
                     tail = obs.rows() - s.offset - rows;
  source_.resize(obs.rows() - rows, B);
  source_.topRows(s.offset) = obs.topRows(s.offset);
  source_.bottomRows(tail) = obs.bottomRows(tail);
  mask_.setOnes(s.instances, B);
  if (s.presence >= 0)
    for (Eigen::Index b = 0; b < B; ++b)
      for (int n = 0; n < s.instances; ++n)
        mask_(n, b) = std::abs(obs(s.offset + Eigen::Index(n) * s.instance_dim + s.presence, b)) > 0.5f ? 1.0f : 0.0f;
  return pair_.Forward(source_, obs.middleRows(s.offset, rows), mask_);
}

const Eigen::MatrixXf& QNet::Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool input_grad) {
  if (!options_.split.enabled()) return mlp_.Backward(dout, input_grad);
  const Eigen::MatrixXf& ds = pair_.Backward(dout, input_grad);
  if (!input_grad) return ds;
  const InstanceSplit& s = options_.split;
  const Eigen::Index rows = Eigen::Index(s.instances) * s.instance_dim, tail = options_.obs_dim - s.offset - rows;
  input_grad_.setZero(options_.obs_dim, ds.cols());
  input_grad_.topRows(s.offset) = ds.topRows(s.offset);
  input_grad_.bottomRows(tail) = ds.bottomRows(tail);
  return input_grad_;
}

}  // namespace coins::nn
