// Sizing a string for bytes that are written into it afterwards, without
// first writing zeros over them (a received big tuple's data: the socket
// writes every byte; zero-filling 64 KiB costs about as much as copying it).
#pragma once

#include <cstddef>
#include <string>

namespace peis::net {

// Makes `s` `bytes` long; its bytes are unspecified until the caller
// writes every one of them.
void resizeForOverwrite(std::string& s, std::size_t bytes);

}  // namespace peis::net
