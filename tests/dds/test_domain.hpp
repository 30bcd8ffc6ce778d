#pragma once
// A DDS domain of the test's own. Tests run in parallel (ctest -j) and several start `cdff node`
// with the same graph: two of them on one domain would answer each other's API calls and read
// each other's samples. Each call claims a domain no other process on this machine holds (an
// exclusive lock on a file named after it in the temporary directory, released when the process
// exits) and returns it; a second call in the same process claims another one.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "cdff/dds/participant.hpp"

namespace cdff::testing {

inline int claimTestDomain() {
  const int domains = dds::kMaxDomainId;  // 1..kMaxDomainId: domain 0 is left to users
  const int start = static_cast<int>(::getpid() % domains);
  for (int k = 0; k < domains; ++k) {
    const int domain = 1 + (start + k) % domains;
    const std::string lock = (std::filesystem::temp_directory_path() /
                              ("cdff-test-dds-domain-" + std::to_string(domain) + ".lock"))
                                 .string();
    const int fd = ::open(lock.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return domain;  // held (fd open) until the exit
    ::close(fd);
  }
  ADD_FAILURE() << "every DDS domain 1.." << domains << " is held by another test process";
  return 1;
}

}  // namespace cdff::testing
