// The codec test schema's encoders and decoders, as the generated service code defines a schema's.
#include "codec_check.hpp"

TETHER_RPC_MESSAGE_DEFINE(codec_Inner)
TETHER_RPC_MESSAGE_DEFINE(codec_Deep)
TETHER_RPC_MESSAGE_DEFINE(codec_All)
