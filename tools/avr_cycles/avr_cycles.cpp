// avr_cycles: runs an AVR image on simavr's ATmega2560 at 16 MHz and reports the exact cycle count of
// each section the image marks with the probes of tests/embedded/cycle_probe.h, and the peak stack.
//
//   avr_cycles IMAGE.elf [--max-cycles N] [--json]
//
// Cycle counts are deterministic: the same image gives the same numbers on any host.
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

// simavr's ELF loader allocates and never frees: under AddressSanitizer, do not report that as a leak
// of this program (the hook is only consulted by sanitizer builds).
extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }

namespace {

// Data-space addresses of the ATmega2560's general-purpose I/O registers.
constexpr avr_io_addr_t kGpior0 = 0x3E;  // command
constexpr avr_io_addr_t kGpior2 = 0x4B;  // section name characters
constexpr uint8_t kCmdStart = 1, kCmdStop = 2, kCmdDone = 0xFF;
constexpr uint8_t kStackPaint = 0xA5;
constexpr uint16_t kDataStart = 0x200;  // first SRAM byte on the ATmega2560

struct Section {
  std::string name;
  uint64_t cycles;
};

struct Probe {
  std::string pending_name;
  uint64_t start_cycle = 0;
  bool running = false;
  bool done = false;
  std::vector<Section> sections;
};

void on_name(avr_t*, avr_io_addr_t, uint8_t v, void* param) {
  static_cast<Probe*>(param)->pending_name.push_back(static_cast<char>(v));
}

void on_command(avr_t* avr, avr_io_addr_t, uint8_t v, void* param) {
  auto* probe = static_cast<Probe*>(param);
  if (v == kCmdStart) {
    probe->start_cycle = avr->cycle;
    probe->running = true;
  } else if (v == kCmdStop && probe->running) {
    probe->sections.push_back({probe->pending_name, avr->cycle - probe->start_cycle});
    probe->pending_name.clear();
    probe->running = false;
  } else if (v == kCmdDone) {
    probe->done = true;
  }
}

int usage() {
  std::fprintf(stderr, "usage: avr_cycles IMAGE.elf [--max-cycles N] [--json]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  const char* image = argv[1];
  uint64_t max_cycles = 2000000000ull;
  bool json = false;
  for (int i = 2; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--max-cycles") && i + 1 < argc) {
      max_cycles = std::strtoull(argv[++i], nullptr, 10);
    } else if (!std::strcmp(argv[i], "--json")) {
      json = true;
    } else {
      return usage();
    }
  }

  elf_firmware_t fw;
  std::memset(&fw, 0, sizeof fw);
  if (elf_read_firmware(image, &fw) != 0) {
    std::fprintf(stderr, "avr_cycles: %s: cannot read the ELF image\n", image);
    return 1;
  }
  avr_t* avr = avr_make_mcu_by_name("atmega2560");
  if (!avr) {
    std::fprintf(stderr, "avr_cycles: simavr has no atmega2560 core\n");
    return 1;
  }
  avr_init(avr);
  avr->frequency = 16000000;
  avr_load_firmware(avr, &fw);

  // Paint the free SRAM so the stack's high-water mark can be read back afterwards.
  const uint32_t static_end = kDataStart + fw.datasize + fw.bsssize;
  for (uint32_t a = static_end; a <= avr->ramend; ++a) avr->data[a] = kStackPaint;

  Probe probe;
  avr_register_io_write(avr, kGpior2, on_name, &probe);
  avr_register_io_write(avr, kGpior0, on_command, &probe);

  int state = cpu_Running;
  while (!probe.done && avr->cycle < max_cycles) {
    state = avr_run(avr);
    if (state == cpu_Done || state == cpu_Crashed) break;
  }
  if (!probe.done) {
    std::fprintf(stderr, "avr_cycles: %s did not signal completion (%s after %llu cycles)\n", image,
                 state == cpu_Crashed ? "crashed" : (state == cpu_Done ? "stopped" : "cycle limit"),
                 static_cast<unsigned long long>(avr->cycle));
    return 1;
  }

  uint32_t low_water = static_end;
  while (low_water <= avr->ramend && avr->data[low_water] == kStackPaint) ++low_water;
  const uint32_t peak_stack = avr->ramend + 1 - low_water;

  uint64_t overhead = 0;
  for (const auto& s : probe.sections)
    if (s.name == "overhead") overhead = s.cycles;

  if (json) {
    std::printf("{\"image\": \"%s\", \"static_ram\": %u, \"peak_stack\": %u, \"sections\": {", image,
                static_end - kDataStart, peak_stack);
    bool first = true;
    for (const auto& s : probe.sections) {
      if (s.name == "overhead") continue;
      std::printf("%s\"%s\": %llu", first ? "" : ", ", s.name.c_str(),
                  static_cast<unsigned long long>(s.cycles - overhead));
      first = false;
    }
    std::printf("}}\n");
  } else {
    std::printf("%-32s %10s %10s\n", "section", "cycles", "us@16MHz");
    for (const auto& s : probe.sections) {
      if (s.name == "overhead") continue;
      const uint64_t c = s.cycles - overhead;
      std::printf("%-32s %10llu %10.1f\n", s.name.c_str(), static_cast<unsigned long long>(c), c / 16.0);
    }
    std::printf("static RAM (data + bss): %u bytes; peak stack: %u bytes; total: %u of 8192\n",
                static_end - kDataStart, peak_stack, static_end - kDataStart + peak_stack);
  }
  avr_terminate(avr);
  return 0;
}
