// Shared by the libFuzzer targets: reporting a finding, and writing the input to a file for readers that take a
// path. Each target defines kTarget, its name, which both put in their messages and file names.
#pragma once
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace pt::fuzz {

extern const char* const kTarget;

// Prints "<target>: <what>: <detail>" and aborts, which libFuzzer records as a finding with the input.
[[noreturn]] inline void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "%s: %s: %s\n", kTarget, what, detail.c_str());
  std::abort();
}

// The input goes to a per-process file in shared memory (RAM), rewritten for each input.
inline std::string write_input(const uint8_t* data, size_t size, const char* extension) {
  const std::string dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
  const std::string path = dir + "/pt_" + kTarget + "_" + std::to_string(getpid()) + extension;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) finding("cannot create the input file", path);
  if (size && std::fwrite(data, 1, size, f) != size) finding("cannot write the input file", path);
  if (std::fclose(f) != 0) finding("cannot close the input file", path);
  return path;
}

}  // namespace pt::fuzz
