#include "quad/vision/frame_pairer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace quad::vision {
namespace {

constexpr double kAssumedPeriodUs = 1e6 / 30.0;
constexpr size_t kIntervalWindow = 31;
constexpr size_t kMaxSkewsKept = 1'000'000;  // 9 h at 30 Hz: the percentiles then describe the first 9 h

}  // namespace

double PairingStats::mean_skew_us() const {
  double sum = 0.0;
  for (double s : skews_us) sum += s;
  return skews_us.empty() ? 0.0 : sum / static_cast<double>(skews_us.size());
}

double PairingStats::max_observed_skew_us() const {
  return skews_us.empty() ? 0.0 : *std::max_element(skews_us.begin(), skews_us.end());
}

double PairingStats::percentile_skew_us(double p) const {
  if (skews_us.empty()) return 0.0;
  std::vector<double> sorted = skews_us;
  std::sort(sorted.begin(), sorted.end());
  const size_t i = std::min(sorted.size() - 1, static_cast<size_t>(p / 100.0 * static_cast<double>(sorted.size())));
  return sorted[i];
}

std::string PairingStats::json() const {
  char buffer[640];
  std::snprintf(buffer, sizeof buffer,
                "{\"pairs\":%llu,\"skew_ms\":{\"mean\":%.3f,\"p95\":%.3f,\"max\":%.3f,\"limit\":%.3f},"
                "\"unpaired\":{\"left\":%llu,\"right\":%llu},\"refused_for_skew\":{\"left\":%llu,\"right\":%llu},"
                "\"missing\":{\"left\":%llu,\"right\":%llu},\"frame_period_ms\":{\"left\":%.3f,\"right\":%.3f}}",
                static_cast<unsigned long long>(pairs), mean_skew_us() / 1e3, percentile_skew_us(95) / 1e3,
                max_observed_skew_us() / 1e3, max_skew_us / 1e3, static_cast<unsigned long long>(unpaired[0]),
                static_cast<unsigned long long>(unpaired[1]), static_cast<unsigned long long>(refused[0]),
                static_cast<unsigned long long>(refused[1]), static_cast<unsigned long long>(missing[0]),
                static_cast<unsigned long long>(missing[1]), period_us[0] / 1e3, period_us[1] / 1e3);
  return buffer;
}

FramePairer::FramePairer(double max_skew_us, size_t max_queue)
    : configured_max_skew_us_(max_skew_us), max_queue_(std::max<size_t>(max_queue, 2)) {
  stats_.max_skew_us = this->max_skew_us();
}

double FramePairer::period_us(int camera) const {
  const std::vector<double>& v = intervals_[camera];
  if (v.empty()) return kAssumedPeriodUs;
  std::vector<double> sorted = v;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  return sorted[sorted.size() / 2];
}

double FramePairer::max_skew_us() const {
  if (configured_max_skew_us_ > 0.0) return configured_max_skew_us_;
  return 0.5 * std::min(period_us(0), period_us(1));
}

void FramePairer::push(int camera, TimedFrame frame) {
  if (seen_[camera]) {
    const double interval = static_cast<double>(frame.time_us - last_time_us_[camera]);
    const double period = period_us(camera);
    // A gap of more than 1.5 periods: the camera (or its capture device) dropped frames. Judged against
    // the period measured so far, before this interval enters it.
    if (intervals_[camera].size() >= 3 && interval > 1.5 * period) {
      stats_.missing[camera] += static_cast<uint64_t>(std::lround(interval / period)) - 1;
    }
    if (interval > 0.0) {
      intervals_[camera].push_back(interval);
      if (intervals_[camera].size() > kIntervalWindow) intervals_[camera].erase(intervals_[camera].begin());
    }
  }
  seen_[camera] = true;
  last_time_us_[camera] = frame.time_us;
  queue_[camera].push_back(std::move(frame));
  // A camera whose partner has stopped must not pile frames up: the oldest go unpaired.
  while (queue_[camera].size() > max_queue_) drop_front(camera, false);
  stats_.period_us[camera] = period_us(camera);
  stats_.max_skew_us = max_skew_us();
}

void FramePairer::drop_front(int camera, bool refused) {
  queue_[camera].pop_front();
  ++stats_.unpaired[camera];
  if (refused) ++stats_.refused[camera];
}

std::optional<std::pair<TimedFrame, TimedFrame>> FramePairer::pop(bool flush) {
  while (!queue_[0].empty() && !queue_[1].empty()) {
    // The older of the two front frames either pairs with the other camera's front frame, or with no one.
    const int older = queue_[0].front().time_us <= queue_[1].front().time_us ? 0 : 1;
    const int newer = 1 - older;
    const TimedFrame& o = queue_[older].front();
    const TimedFrame& n = queue_[newer].front();
    const double skew = static_cast<double>(n.time_us - o.time_us);
    if (queue_[older].size() >= 2) {
      // The older camera's next frame is nearer to n: o has no partner.
      if (std::fabs(static_cast<double>(queue_[older][1].time_us - n.time_us)) < skew) {
        drop_front(older, false);
        continue;
      }
    } else if (!flush && skew > 0.5 * period_us(older)) {
      return std::nullopt;  // the older camera's next frame may still be nearer: wait for it
    }
    if (skew > max_skew_us()) {
      drop_front(older, true);
      continue;
    }
    std::pair<TimedFrame, TimedFrame> pair;
    pair.first = std::move(queue_[0].front());
    pair.second = std::move(queue_[1].front());
    queue_[0].pop_front();
    queue_[1].pop_front();
    ++stats_.pairs;
    if (stats_.skews_us.size() < kMaxSkewsKept) stats_.skews_us.push_back(skew);
    return pair;
  }
  if (flush) {
    // The streams have ended: what is left has no partner.
    for (int camera = 0; camera < 2; ++camera) {
      while (!queue_[camera].empty()) drop_front(camera, false);
    }
  }
  return std::nullopt;
}

}  // namespace quad::vision
