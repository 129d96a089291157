/// @file MessageHandler.h
/// RomiSerial compatibility header: the handler table row. Same content as IRomiSerial.h (the reference
/// declares `MessageHandler` there); provided so either include works.
#pragma once

#include "IRomiSerial.h"
