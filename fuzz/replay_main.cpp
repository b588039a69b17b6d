// A main for the fuzz harnesses in builds without libFuzzer (the ./cairn test build, gcc): runs every file of
// a corpus folder through LLVMFuzzerTestOneInput, then N inputs mutated from them (bytes flipped, set to edge
// values, inserted, removed, spliced; a fixed seed, so a failure replays). The coverage-guided runs are
// bench/fuzz.sh's (clang, libFuzzer). Usage: HARNESS_replay CORPUS_DIR [MUTATIONS] [SEED]
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::vector<std::uint8_t> Mutate(std::vector<std::uint8_t> in, std::mt19937_64& rng) {
  const auto pick = [&](std::size_t n) {
    return n == 0 ? std::size_t{0} : static_cast<std::size_t>(rng() % n);
  };
  static const std::uint8_t kEdges[] = {0x00, 0x01, 0x7f, 0x80, 0xfe, 0xff};
  const int edits = 1 + static_cast<int>(rng() % 8);
  for (int e = 0; e < edits; ++e) {
    switch (rng() % 6) {
      case 0:  // flip a bit
        if (!in.empty()) in[pick(in.size())] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      case 1:  // an edge value
        if (!in.empty()) in[pick(in.size())] = kEdges[rng() % sizeof(kEdges)];
        break;
      case 2:  // insert random bytes
        for (std::size_t k = 0, n = 1 + pick(16); k < n; ++k) {
          in.insert(in.begin() + static_cast<std::ptrdiff_t>(pick(in.size() + 1)),
                    static_cast<std::uint8_t>(rng()));
        }
        break;
      case 3:  // remove a span
        if (!in.empty()) {
          const std::size_t at = pick(in.size());
          in.erase(in.begin() + static_cast<std::ptrdiff_t>(at),
                   in.begin() + static_cast<std::ptrdiff_t>(std::min(in.size(), at + 1 + pick(32))));
        }
        break;
      case 4:  // truncate
        in.resize(pick(in.size() + 1));
        break;
      default:  // a 4-byte edge integer (sizes, counts)
        if (in.size() >= 4) {
          const std::uint32_t v = (rng() % 2) ? 0xffffffffu : static_cast<std::uint32_t>(1u << (rng() % 32));
          const std::size_t at = pick(in.size() - 3);
          for (int b = 0; b < 4; ++b) in[at + b] = static_cast<std::uint8_t>(v >> (8 * b));
        }
        break;
    }
  }
  return in;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR [MUTATIONS] [SEED]\n", argv[0]);
    return 2;
  }
  const long mutations = argc > 2 ? std::strtol(argv[2], nullptr, 10) : 2000;
  std::mt19937_64 rng(argc > 3 ? std::strtoull(argv[3], nullptr, 10) : 15);
  std::vector<std::vector<std::uint8_t>> corpus;
  for (const auto& entry : std::filesystem::directory_iterator(argv[1])) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path(), std::ios::binary);
    corpus.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  if (corpus.empty()) {
    std::fprintf(stderr, "%s: no corpus files in %s\n", argv[0], argv[1]);
    return 2;
  }
  // With CAIRN_FUZZ_LAST=FILE each input is written there before it runs: the one a crash leaves is the
  // culprit.
  const char* last = std::getenv("CAIRN_FUZZ_LAST");
  const auto run = [&](const std::vector<std::uint8_t>& input) {
    if (last != nullptr)
      std::ofstream(last, std::ios::binary | std::ios::trunc)
          .write(reinterpret_cast<const char*>(input.data()), static_cast<std::streamsize>(input.size()));
    LLVMFuzzerTestOneInput(input.data(), input.size());
  };
  const auto start = std::chrono::steady_clock::now();
  for (const auto& input : corpus) run(input);
  for (long i = 0; i < mutations; ++i) run(Mutate(corpus[rng() % corpus.size()], rng));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%s: %zu corpus inputs and %ld mutations in %.1f s, no crash\n", argv[0], corpus.size(),
              mutations, s);
  return 0;
}
