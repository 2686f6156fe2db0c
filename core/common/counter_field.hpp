#pragma once
// One counter of a statistics record: its key, the member and its unit. Each record lists
// its counters once, in a table of these (e.g. kAssemblyCounterFields), and whatever sums,
// prints or publishes them iterates that table instead of naming each member again.

#include <cstdint>

namespace lidarfuse::core {

template <class Record>
struct CounterField {
    const char* name;  // the key the diagnostics and the command lines print
    std::uint64_t Record::*member;
    const char* unit;
};

}  // namespace lidarfuse::core
