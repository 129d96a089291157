// Host back end of crc.hpp: Boost.CRC. Both checksums are inline in crc.hpp (the object is Boost's
// `crc_optimal` engine); only the back end's name is compiled here.
#include "tether/core/crc.hpp"

namespace tether {

const char* crc_backend_name() { return "boost"; }

}  // namespace tether
