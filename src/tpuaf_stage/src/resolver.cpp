// World files: plain ones are resolved once by the Python parser (tpuaf_stage.resolve) in a child
// process; its one-line error is relayed (tpuaf_stage/resolver.hpp).
#include "tpuaf_stage/resolver.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "tpuaf_stage/world_file.hpp"

namespace tpuaf_stage {

std::string run_resolver(const std::string& world, std::string& folder) {
  char tmpl[] = "/tmp/tpuaf_stage_world.XXXXXX";
  if (!mkdtemp(tmpl)) throw WorldFileError("cannot create a temporary folder for the world");
  folder = tmpl;
  const char* python = std::getenv("TPUAF_PYTHON");
  const std::string exe = python && *python ? python : "/usr/bin/python3";
  const std::string err_file = folder + "/resolve.err";
  const std::string out_file = folder + "/resolve.out";
  pid_t pid = fork();
  if (pid < 0) throw WorldFileError("cannot start the world file parser");
  if (pid == 0) {
    FILE* e = std::freopen(err_file.c_str(), "w", stderr);
    FILE* o = std::freopen(out_file.c_str(), "w", stdout);
    (void)e;
    (void)o;
    execl(exe.c_str(), exe.c_str(), "-m", "tpuaf_stage.resolve", world.c_str(), folder.c_str(),
          static_cast<char*>(nullptr));
    std::fprintf(stderr, "cannot run %s: %s\n", exe.c_str(), std::strerror(errno));
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream err_in(err_file);
  std::string line, last;
  while (std::getline(err_in, line)) {
    if (!line.empty()) last = line;
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw WorldFileError(last.empty() ? world + ": the world file parser failed" : last);
  }
  return folder + "/world.resolved.yaml";
}

void remove_folder(const std::string& folder) {
  if (folder.empty()) return;
  for (const char* f :
       {"world.resolved.yaml", "world.occupancy.pgm", "resolve.err", "resolve.out"}) {
    std::remove((folder + "/" + f).c_str());
  }
  rmdir(folder.c_str());
}

}  // namespace tpuaf_stage
