// Codec cost on the host: encoding and parsing a HIL_SENSOR frame (the message of every HIL step), and
// what signing adds: SHA-256 throughput, signing a frame, verifying one.
#include <benchmark/benchmark.h>

#include <cstring>
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

mav::SigningKey bench_key() {
  mav::SigningKey key;
  for (size_t i = 0; i < mav::kSigningKeyLength; ++i) key.bytes[i] = static_cast<uint8_t>(i * 37 + 11);
  return key;
}

void BM_Sha256(benchmark::State& state) {
  std::vector<uint8_t> data(static_cast<size_t>(state.range(0)));
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<uint8_t>(i);
  uint8_t digest[mav::kSha256DigestLength];
  for (auto _ : state) {
    mav::sha256(data.data(), data.size(), digest);
    benchmark::DoNotOptimize(digest);
    data[0] = digest[0];
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_Sha256)->Arg(64)->Arg(1024);

// Encode and sign (encode_signed()): the cost per frame sent on a signed link. The signed HIL_SENSOR frame
// is 87 bytes, so SHA-256 runs over 32 + 81 bytes: two blocks.
void BM_EncodeAndSignHilSensor(benchmark::State& state) {
  const mav::SigningKey key = bench_key();
  mav::SigningClock clock(1000000);
  mav::Signer signer(key, clock, 1);
  mav::Sender sender(1, 200);
  mav::HilSensor sample = typical_sample();
  uint8_t frame[mav::max_frame_length<mav::HilSensor>(true)];
  for (auto _ : state) {
    sample.time_usec += 10000;
    benchmark::DoNotOptimize(sample);
    const size_t size = mav::encode_signed(sender, signer, sample, frame, sizeof frame);
    benchmark::DoNotOptimize(frame);
    if (size == 0) state.SkipWithError("signing failed");
  }
}
BENCHMARK(BM_EncodeAndSignHilSensor);

// SignatureVerifier::check() alone on signed HIL_SENSOR frames already delivered by the parser (64
// distinct frames; the stream is forgotten after each pass so that none counts as a replay).
void BM_VerifyHilSensor(benchmark::State& state) {
  const mav::SigningKey key = bench_key();
  mav::SigningClock sender_clock(1000000);
  mav::Signer signer(key, sender_clock, 1);
  mav::Sender sender(1, 200);
  std::vector<std::vector<uint8_t>> bytes;
  std::vector<mav::Frame> frames;
  mav::Parser parser;
  for (int i = 0; i < 64; ++i) {
    mav::HilSensor sample = typical_sample();
    sample.time_usec += static_cast<uint64_t>(i) * 10000;
    std::vector<uint8_t> frame(mav::max_frame_length<mav::HilSensor>(true));
    frame.resize(mav::encode_signed(sender, signer, sample, frame.data(), frame.size()));
    bytes.push_back(frame);
  }
  for (const std::vector<uint8_t>& b : bytes) {  // the parser's view, moved onto our own copy of the bytes
    parser.feed(b.data(), b.size(), [&](const mav::Frame& f) {
      mav::Frame own = f;
      own.bytes = b.data();
      own.payload = b.data() + mav::kHeaderLength;
      own.signature = b.data() + b.size() - mav::kSignatureLength;
      frames.push_back(own);
    });
  }
  if (frames.size() != 64) state.SkipWithError("frames lost");
  mav::SigningClock clock(1000000);
  mav::SignatureVerifier verifier(key, clock);
  verifier.set_require_signed(true);
  size_t accepted = 0;
  for (auto _ : state) {
    for (const mav::Frame& f : frames) accepted += mav::accepted(verifier.check(f)) ? 1 : 0;
    verifier.forget_streams();
  }
  if (accepted != static_cast<size_t>(state.iterations()) * 64) state.SkipWithError("frames rejected");
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations()) * 64);
  state.counters["ns_per_frame"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 64, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_VerifyHilSensor);

}  // namespace
