// RunQueue: runs jobs 0..n-1, each a whole `coins` run of an experiment, either one after another
// or several at once with one DDS domain per concurrent run.
//
// With no domains the jobs run in order on the calling thread, and each gets no domain (it keeps
// the one its config names). With domains D1..Dk, k workers run the jobs in index order, worker i
// always on domain Di: two runs that are live at once never share a domain, so their processes
// cannot hear each other. After the first failed job no new job starts; the jobs already running
// end as they would (a run in flight is never cut short by another's failure), and that first
// error is returned. A job that reports a stop request ends the queue the same way.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "common/status.h"

namespace coins {

// one job: its index and the domain it runs on (nullopt: the run's own)
using RunJob = std::function<Status(size_t job, std::optional<int> domain)>;

Status RunQueue(size_t jobs, const std::vector<int>& domains, const RunJob& run);

// checks a --domains list: distinct DDS domain ids Fast DDS's default ports can serve (0-kMaxDdsDomain);
// the error names the offending entry
Status CheckDomains(const std::vector<int>& domains);

}  // namespace coins
