// The fuzz targets as plain functions: the libFuzzer harnesses (fuzz/*_fuzz.cpp, RADLAB_FUZZ
// builds only) call them on mutated input, and the default test suite replays every committed
// corpus file through them (tests/fuzz/fuzz_corpus_test.cpp), so each finding stays a regression
// test.
//
// Each returns normally when the input is read or refused with a radlab::Error (the documented
// way to refuse input: exit 2/3/4 on the command line); anything else escapes and is a finding.
#pragma once

#include <cstddef>
#include <cstdint>

namespace radlab::fuzz {

// OBJ text, `#--8<--`, MTL text (m.mtl): load_scene (read + validate), then the default mesh.
void run_obj(const uint8_t* data, size_t size);
// main.mgf, `#--8<--`, inc.mgf: load_scene, then the default mesh.
void run_mgf(const uint8_t* data, size_t size);
// An experiment file: read_experiment and plan_sweep (what `radlab run --list` does).
void run_toml(const uint8_t* data, size_t size);
// sweep.json, `#--8<--`, summary.csv, `#--8<--`, trace.csv of one shard: merge_sweeps.
void run_merge(const uint8_t* data, size_t size);

}  // namespace radlab::fuzz
