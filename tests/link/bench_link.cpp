// Codec cost on the host: encoding and parsing a HIL_SENSOR frame (the message of every HIL step).
#include <benchmark/benchmark.h>

#include <vector>

#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

mav::HilSensor typical_sample() {
  mav::HilSensor s;
  s.time_usec = 123456789;
  s.xacc = 0.12f;
  s.yacc = -0.07f;
  s.zacc = -9.81f;
  s.xgyro = 0.001f;
  s.ygyro = -0.002f;
  s.zgyro = 0.0005f;
  s.xmag = 0.21f;
  s.ymag = 0.01f;
  s.zmag = 0.43f;
  s.fields_updated = 0x1FF;
  return s;
}

void BM_EncodeHilSensor(benchmark::State& state) {
  mav::Sender sender(1, 200);
  mav::HilSensor sample = typical_sample();
  uint8_t frame[mav::max_frame_length<mav::HilSensor>()];
  size_t bytes = 0;
  for (auto _ : state) {
    sample.time_usec += 10000;
    benchmark::DoNotOptimize(sample);
    const size_t size = sender.encode(sample, frame, sizeof frame);
    benchmark::DoNotOptimize(frame);
    bytes += size;
  }
  state.SetBytesProcessed(static_cast<int64_t>(bytes));
}
BENCHMARK(BM_EncodeHilSensor);

// Parse one whole frame byte by byte and decode it into the struct (what the firmware does per step).
void BM_ParseAndDecodeHilSensor(benchmark::State& state) {
  mav::Sender sender(1, 200);
  std::vector<uint8_t> stream;
  for (int i = 0; i < 64; ++i) {  // distinct frames, so the work is not a replay of one cached pattern
    mav::HilSensor sample = typical_sample();
    sample.time_usec += static_cast<uint64_t>(i) * 10000;
    uint8_t frame[mav::max_frame_length<mav::HilSensor>()];
    const size_t size = sender.encode(sample, frame, sizeof frame);
    stream.insert(stream.end(), frame, frame + size);
  }
  mav::Parser parser;
  mav::HilSensor decoded;
  size_t frames = 0;
  for (auto _ : state) {
    size_t before = frames;
    for (uint8_t b : stream) {
      parser.feed(b, [&](const mav::Frame& f) { frames += mav::decode(f, decoded) ? 1 : 0; });
    }
    benchmark::DoNotOptimize(decoded);
    if (frames - before != 64) state.SkipWithError("frames lost");
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * 64);
  state.counters["ns_per_frame"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 64, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ParseAndDecodeHilSensor);

}  // namespace
