// What peis-inspect prints about a recording: the header (who recorded
// what, when, whether it ended cleanly), totals and rates, and one line per
// tuple; as text for people or as one JSON object. Pure.
#pragma once

#include <string>

#include "recorder/recording_reader.h"

namespace peis::recorder {

// The seconds the recording covers: started .. ended when the recorder
// wrote them, else from the first to the last event.
double spanSeconds(const RecordingSummary& summary);

std::string inspectText(const RecordingSummary& summary, const std::string& path);
std::string inspectJson(const RecordingSummary& summary, const std::string& path);

}  // namespace peis::recorder
