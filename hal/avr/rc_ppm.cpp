// PPM-sum input of the APM 2.5 (PL1 = ICP5, from the ATmega32U2 encoder): Timer5 captures every rising
// edge; a channel's pulse width is the time between successive edges, a gap over 2.7 ms ends a frame.
#include <avr/interrupt.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

constexpr uint16_t kSyncGapUs = 2700;       // longer than any channel (<= 2100 us), shorter than the sync
constexpr uint8_t kMinChannels = 4;         // a frame with fewer channels is noise
constexpr uint16_t kMinPulseUs = 800, kMaxPulseUs = 2200;

volatile uint16_t g_last_edge = 0;
volatile uint8_t g_channel = 0xFF;          // 0xFF: waiting for the first sync gap
uint16_t g_building[kRcChannels];
volatile uint16_t g_frame[kRcChannels];
volatile uint8_t g_frame_count = 0;
volatile bool g_frame_new = false;

}  // namespace

void start_rc() {
  DDRL &= static_cast<uint8_t>(~_BV(PL1));
  TCCR5B |= _BV(ICNC5) | _BV(ICES5);  // noise canceller, rising edge (Timer5 runs: clock.cpp)
  TIFR5 = _BV(ICF5);
  TIMSK5 |= _BV(ICIE5);
}

void on_capture(uint16_t edge) {
  const uint16_t width_us = static_cast<uint16_t>(edge - g_last_edge) / kTicksPerUs;
  g_last_edge = edge;
  if (width_us > kSyncGapUs) {
    if (g_channel != 0xFF && g_channel >= kMinChannels) {
      for (uint8_t i = 0; i < g_channel; ++i) g_frame[i] = g_building[i];
      g_frame_count = g_channel;
      g_frame_new = true;
    }
    g_channel = 0;
  } else if (g_channel < kRcChannels) {
    if (width_us < kMinPulseUs || width_us > kMaxPulseUs) g_channel = 0xFF;  // glitch: drop this frame
    else g_building[g_channel++] = width_us;
  }
}

}  // namespace avr

bool rc_read(RcFrame& out) {
  const uint8_t sreg = SREG;
  cli();
  const bool fresh = avr::g_frame_new;
  if (fresh) {
    for (uint8_t i = 0; i < kRcChannels; ++i) out.pulse_us[i] = avr::g_frame[i];
    out.count = avr::g_frame_count;
    avr::g_frame_new = false;
  }
  SREG = sreg;
  return fresh;
}

}  // namespace hal
}  // namespace quad

ISR(TIMER5_CAPT_vect) { quad::hal::avr::on_capture(ICR5); }
