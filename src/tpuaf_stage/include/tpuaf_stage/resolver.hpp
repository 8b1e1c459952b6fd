// Plain world files -> their resolved form, by the one parser (Python): the node runs
// `python3 -m tpuaf_stage.resolve WORLD TMPDIR` once at start-up (docs/SIMULATOR.md).
#pragma once

#include <string>

namespace tpuaf_stage {

// Resolves world into a new temporary folder (folder is set once created, for remove_folder) and
// returns the resolved file; throws WorldFileError with the parser's last error line.
// $TPUAF_PYTHON overrides /usr/bin/python3.
std::string run_resolver(const std::string& world, std::string& folder);

// Removes the files run_resolver wrote and their folder ("" = nothing to do).
void remove_folder(const std::string& folder);

}  // namespace tpuaf_stage
