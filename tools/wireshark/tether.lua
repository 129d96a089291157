-- Tether: Wireshark dissector for Tether captures (pcapng written by `tether ... --record`).
--
-- A capture has one interface per device link, link type 147 (LINKTYPE_USER0), whose description names
-- the codec: `tether codec=romi baud=115200 transport=serial` (docs/captures.md). Each packet is one frame
-- of that codec as it crossed the wire, its direction in the packet flags (1 device->host, 2 host->device);
-- bytes that formed no frame carry the comment `unframed[: reason]`, link events `link: ...`.
--
-- Decoded: Romi (opcode, arguments, id, CRC-8/SMBUS, log lines, error codes), proxy and proxy-compat (COBS,
-- CRC-16/MCRF4XX, the protobuf message through Wireshark's protobuf dissector), Elcano (type, fields,
-- generation D's CRC), rpc (the envelope, and the method's messages by name when the schema is found).
-- Requests and their answers are linked (Romi by id, proxy and rpc by message id) with the response time.
--
-- Install: copy into Wireshark's Lua plugin folder (~/.local/lib/wireshark/plugins); the protobuf messages
-- are named when Tether's .proto folder (share/tether/proto) is in Protobuf's search paths (docs/wireshark.md).
-- Written for Wireshark 4.0's Lua 5.2 API.

-- One copy only: with the package's copy and one in the personal folder both loaded, the second would fail
-- to register the same protocol again (an error dialog at every start). The first one loaded stays.
local registered, tether = pcall(Proto, "tether", "Tether")
if not registered then return end

-------------------------------------------------------------------------------------------------------------
-- Preferences

tether.prefs.schema_dirs = Pref.string("rpc schema folders", "",
  "Folders (separated by ':') where an rpc capture's schema (its interface's schema=) is looked for, "
  .. "besides the folder Wireshark was started in. Add the same folders to Protobuf's search paths.")

-------------------------------------------------------------------------------------------------------------
-- Fields

local direction_names = { [1] = "device -> host", [2] = "host -> device" }
-- Wireshark's checksum status values (proto_checksum_vals).
local checksum_names = { [0] = "Bad", [1] = "Good", [2] = "Unverified", [3] = "Not present" }
local CK_BAD, CK_GOOD = 0, 1

local romi_errors = {
  [0] = "no error",
  [-1] = "envelope too long", [-2] = "invalid id", [-3] = "invalid crc", [-4] = "crc mismatch",
  [-5] = "expected end of envelope", [-6] = "missing metadata", [-7] = "invalid dummy metadata",
  [-8] = "unexpected char", [-9] = "too many arguments", [-10] = "value out of range",
  [-11] = "string too long", [-12] = "invalid string", [-13] = "too many strings", [-14] = "invalid opcode",
  [-15] = "duplicate message", [-16] = "unknown opcode", [-17] = "bad number of arguments",
  [-18] = "missing string argument", [-19] = "bad string argument", [-20] = "handler sent no reply",
  [-21] = "client: invalid opcode", [-22] = "client: request too long", [-23] = "client: empty response",
  [-24] = "client: empty request", [-25] = "client: no reply from the device", [-26] = "client: invalid JSON",
  [-27] = "client: badly formed response", [-28] = "client: invalid error response",
  [-30] = "controller timeout: request not completed within 1 s",
  [-31] = "reply too long for the device's buffer",
  [-32] = "string contains a reserved character (# : \" CR LF)", [-33] = "transport error",
}

local rpc_errors = {
  [0xFF01] = "unknown method", [0xFF02] = "bad request", [0xFF03] = "not unary", [0xFF04] = "not streaming",
  [0xFF05] = "period too short", [0xFF06] = "request too large", [0xFF07] = "reply too large",
  [0xFF08] = "bad envelope", [0xFF09] = "unknown message", [0xFF0A] = "streams full",
}

local elcano_types = { D = "drive", S = "sensor", G = "goal", X = "segment" }

local f = {
  device = ProtoField.string("tether.device", "Device"),
  codec = ProtoField.string("tether.codec", "Codec"),
  baud = ProtoField.string("tether.baud", "Baud"),
  transport = ProtoField.string("tether.transport", "Transport"),
  direction = ProtoField.uint8("tether.direction", "Direction", base.DEC, direction_names),
  unframed = ProtoField.string("tether.unframed", "Unframed bytes"),
  link_event = ProtoField.string("tether.link_event", "Link event"),
  text = ProtoField.string("tether.text", "Text"),
  response_in = ProtoField.framenum("tether.response_in", "Response in", base.NONE, frametype.RESPONSE),
  request_in = ProtoField.framenum("tether.request_in", "Request in", base.NONE, frametype.REQUEST),
  ack_in = ProtoField.framenum("tether.ack_in", "Ack in", base.NONE, frametype.ACK),
  response_time = ProtoField.relative_time("tether.response_time", "Response time"),
  resend_of = ProtoField.framenum("tether.resend_of", "Re-send of", base.NONE, frametype.DUP_ACK),

  romi_kind = ProtoField.string("tether.romi.kind", "Frame"),
  romi_opcode = ProtoField.string("tether.romi.opcode", "Opcode"),
  romi_args = ProtoField.string("tether.romi.args", "Arguments"),
  romi_arg = ProtoField.string("tether.romi.arg", "Argument"),
  romi_code = ProtoField.int32("tether.romi.code", "Code"),
  romi_error = ProtoField.string("tether.romi.error", "Error"),
  romi_value = ProtoField.string("tether.romi.value", "Value"),
  romi_log = ProtoField.string("tether.romi.log", "Log text"),
  romi_id = ProtoField.uint8("tether.romi.id", "Id", base.DEC),
  romi_crc = ProtoField.uint8("tether.romi.crc", "CRC-8", base.HEX),
  romi_crc_computed = ProtoField.uint8("tether.romi.crc.computed", "Computed CRC-8", base.HEX),
  romi_crc_status = ProtoField.uint8("tether.romi.crc.status", "CRC-8 status", base.DEC, checksum_names),

  cobs_delimiter = ProtoField.bytes("tether.cobs.leading_delimiter", "Leading delimiter"),
  cobs_length = ProtoField.uint16("tether.cobs.decoded_length", "Decoded length"),
  crc16 = ProtoField.uint16("tether.crc16", "CRC-16", base.HEX),
  crc16_computed = ProtoField.uint16("tether.crc16.computed", "Computed CRC-16", base.HEX),
  crc16_status = ProtoField.uint8("tether.crc16.status", "CRC-16 status", base.DEC, checksum_names),
  payload = ProtoField.bytes("tether.payload", "Payload"),
  message = ProtoField.string("tether.message", "Message"),
  message_id = ProtoField.uint32("tether.message_id", "Message id"),
  acked_id = ProtoField.uint32("tether.ack.message_id", "Acked message id"),
  refused = ProtoField.bool("tether.ack.refused", "Refused"),

  rpc_method = ProtoField.string("tether.rpc.method", "Method"),
  rpc_method_index = ProtoField.uint32("tether.rpc.method_index", "Method index"),
  rpc_type = ProtoField.string("tether.rpc.type", "Message type"),
  rpc_call = ProtoField.uint32("tether.rpc.call", "Call"),
  rpc_stream = ProtoField.uint32("tether.rpc.stream", "Stream"),
  rpc_seq = ProtoField.uint32("tether.rpc.seq", "Stream sequence"),
  rpc_code = ProtoField.uint32("tether.rpc.error_code", "Error code", base.DEC),
  rpc_error = ProtoField.string("tether.rpc.error", "Error"),

  elcano_generation = ProtoField.string("tether.elcano.generation", "Generation"),
  elcano_type = ProtoField.string("tether.elcano.type", "Type"),
  elcano_number = ProtoField.int32("tether.elcano.number", "Number (n)"),
  elcano_speed = ProtoField.int32("tether.elcano.speed", "Speed cm/s (s)"),
  elcano_angle = ProtoField.int32("tether.elcano.angle", "Angle (a)"),
  elcano_obstacle = ProtoField.int32("tether.elcano.obstacle", "Obstacle mm (o)"),
  elcano_bearing = ProtoField.int32("tether.elcano.bearing", "Bearing (b)"),
  elcano_probability = ProtoField.int32("tether.elcano.probability", "Probability (r)"),
  elcano_east = ProtoField.int32("tether.elcano.east", "East cm (p)"),
  elcano_north = ProtoField.int32("tether.elcano.north", "North cm"),
  elcano_crc = ProtoField.uint8("tether.elcano.crc", "CRC-8", base.DEC),
  elcano_crc_computed = ProtoField.uint8("tether.elcano.crc.computed", "Computed CRC-8", base.DEC),
  elcano_crc_status = ProtoField.uint8("tether.elcano.crc.status", "CRC-8 status", base.DEC, checksum_names),
  elcano_error = ProtoField.string("tether.elcano.error", "Error"),
}
local field_list = {}
for _, field in pairs(f) do field_list[#field_list + 1] = field end
tether.fields = field_list

local e = {
  unframed = ProtoExpert.new("tether.unframed.expert", "Bytes that formed no frame",
    expert.group.PROTOCOL, expert.severity.WARN),
  link_event = ProtoExpert.new("tether.link_event.expert", "Link event", expert.group.SEQUENCE,
    expert.severity.NOTE),
  bad_crc = ProtoExpert.new("tether.bad_crc", "Bad checksum", expert.group.CHECKSUM, expert.severity.ERROR),
  malformed = ProtoExpert.new("tether.malformed", "Malformed frame", expert.group.MALFORMED,
    expert.severity.ERROR),
  error_reply = ProtoExpert.new("tether.error_reply", "Error reply", expert.group.RESPONSE_CODE,
    expert.severity.WARN),
  refused = ProtoExpert.new("tether.refused", "Refused by the device", expert.group.RESPONSE_CODE,
    expert.severity.WARN),
  no_schema = ProtoExpert.new("tether.rpc.no_schema", "rpc schema not found", expert.group.UNDECODED,
    expert.severity.WARN),
  not_tether = ProtoExpert.new("tether.not_tether", "Not a Tether link", expert.group.UNDECODED,
    expert.severity.WARN),
}
tether.experts = { e.unframed, e.link_event, e.bad_crc, e.malformed, e.error_reply, e.refused, e.no_schema,
  e.not_tether }

local fx_description = Field.new("frame.interface_description")
local fx_name = Field.new("frame.interface_name")
local fx_interface = Field.new("frame.interface_id")
local fx_direction = Field.new("frame.packet_flags_direction")
local fx_comment = Field.new("frame.comment")

local protobuf = Dissector.get("protobuf")
local data_dissector = Dissector.get("data")

-------------------------------------------------------------------------------------------------------------
-- Checksums (Lua 5.2: bit32)

local band, bxor, rshift, lshift = bit32.band, bit32.bxor, bit32.rshift, bit32.lshift

-- CRC-8/SMBUS: poly 0x07, init 0, not reflected (Romi's frames, Elcano generation D).
local function crc8_smbus(s, from, to)
  local crc = 0
  for i = from, to do
    crc = bxor(crc, s:byte(i))
    for _ = 1, 8 do
      if band(crc, 0x80) ~= 0 then crc = band(bxor(lshift(crc, 1), 0x07), 0xFF) else crc = band(lshift(crc, 1), 0xFF) end
    end
  end
  return crc
end

-- CRC-16/MCRF4XX: poly 0x1021 reflected (0x8408), init 0xFFFF, no final xor (the proxy's frames).
local function crc16_mcrf4xx(s, from, to)
  local crc = 0xFFFF
  for i = from, to do
    crc = bxor(crc, s:byte(i))
    for _ = 1, 8 do
      if band(crc, 1) ~= 0 then crc = bxor(rshift(crc, 1), 0x8408) else crc = rshift(crc, 1) end
    end
  end
  return crc
end

-------------------------------------------------------------------------------------------------------------
-- The link: interface description, per-interface state

local function percent_decode(s)
  return (s:gsub("%%(%x%x)", function(h) return string.char(tonumber(h, 16)) end))
end

-- `tether codec=romi baud=115200 ...` -> { codec = "romi", ... }, or nil when it is not Tether's.
local link_cache = {}
local function parse_description(description)
  if not description then return nil end
  local cached = link_cache[description]
  if cached ~= nil then return cached or nil end
  local words = {}
  for word in description:gmatch("%S+") do words[#words + 1] = word end
  if words[1] ~= "tether" then
    link_cache[description] = false
    return nil
  end
  local link = {}
  for i = 2, #words do
    local key, value = words[i]:match("^([^=]+)=(.*)$")
    if key then link[key] = percent_decode(value) end
  end
  link_cache[description] = link
  return link
end

-- Request/response state, rebuilt on every (re)dissection of the file (init) and filled on the first pass.
local pending      -- [interface .. key] = { frame =, time =, bytes = }
local linked       -- [frame] = { request =, response =, ack =, time =, resend_of = }
local schemas      -- [file name] = parsed schema or false

local function reset_state()
  pending, linked, schemas, link_cache = {}, {}, {}, {}
end
reset_state()
function tether.init() reset_state() end

local function link_of(frame)
  local l = linked[frame]
  if not l then l = {}; linked[frame] = l end
  return l
end

-- Request sent (first pass): remembered under `key`; the same bytes again under the same key are a re-send,
-- answered or not (a client sends a request again after an error answer too: a damaged request's, say).
-- `window`: how long (seconds) the same bytes still count as a re-send where ids wrap quickly (Romi's
-- 8-bit ids: the host's call budget); nil: always.
local function note_request(pinfo, key, bytes, window)
  local previous = pending[key]
  if previous and previous.bytes == bytes and (not window or pinfo.abs_ts - previous.time <= window) then
    link_of(pinfo.number).resend_of = previous.frame
  end
  pending[key] = { frame = pinfo.number, time = pinfo.abs_ts, bytes = bytes }
end

-- Answer received (first pass): linked to the latest request under `key` (`kind`: response or ack).
local function note_answer(pinfo, key, kind, completes)
  local request = pending[key]
  if not request then return nil end
  local answer = link_of(pinfo.number)
  answer.request = request.frame
  answer.time = pinfo.abs_ts - request.time
  local req = link_of(request.frame)
  if kind == "ack" then
    if not req.ack then req.ack = pinfo.number end
    if completes then request.answered = true end
  else
    if not req.response then req.response = pinfo.number end
    request.answered = true
  end
  return request
end

local function nstime_of(seconds)
  local us = math.floor(seconds * 1e6 + 0.5)
  if us < 0 then us = 0 end
  return NSTime.new(math.floor(us / 1e6), (us % 1000000) * 1000)
end

-- The links of this frame; `ack_answers`: an ack is the request's answer (proxy), not a receipt (rpc).
local function show_links(pinfo, tree, tvb, ack_answers)
  local l = linked[pinfo.number]
  if not l then return end
  local zero = tvb(0, 0)
  local response = l.response or (ack_answers and l.ack)
  if response then tree:add(f.response_in, zero, response):set_generated() end
  if l.ack and not ack_answers then tree:add(f.ack_in, zero, l.ack):set_generated() end
  if l.resend_of then tree:add(f.resend_of, zero, l.resend_of):set_generated() end
  if l.request then
    tree:add(f.request_in, zero, l.request):set_generated()
    tree:add(f.response_time, zero, nstime_of(l.time)):set_generated()
  end
end

-------------------------------------------------------------------------------------------------------------
-- Romi: `#<opcode>[<args>]:<id><crc>\r\n`, `#!<text>:xxxx\r\n`

-- Splits `a,"b,c",[1,2]` at its top-level commas (strings and brackets kept whole): { {text, offset} }.
local function split_values(s, base_offset)
  local values, depth, quoted, start = {}, 0, false, 1
  local i = 1
  while i <= #s do
    local c = s:sub(i, i)
    if quoted then
      if c == "\\" then i = i + 1 elseif c == '"' then quoted = false end
    elseif c == '"' then quoted = true
    elseif c == "[" or c == "{" then depth = depth + 1
    elseif c == "]" or c == "}" then depth = depth - 1
    elseif c == "," and depth == 0 then
      values[#values + 1] = { s:sub(start, i - 1), base_offset + start - 1 }
      start = i + 1
    end
    i = i + 1
  end
  if #s > 0 then values[#values + 1] = { s:sub(start), base_offset + start - 1 } end
  return values
end

-- A frame's bytes shown as text: anything but printable ASCII as \xNN (a line hit by noise is not UTF-8,
-- which Wireshark's tree, columns and JSON output expect of a string).
local function printable(s)
  return (s:gsub("[^\32-\126]", function(c) return string.format("\\x%02x", c:byte()) end))
end

local function dissect_romi(tvb, pinfo, tree, link, direction)
  local raw = tvb:raw()
  local line_end = #raw
  while line_end > 0 and (raw:byte(line_end) == 10 or raw:byte(line_end) == 13) do line_end = line_end - 1 end
  local line = raw:sub(1, line_end)
  local t = tree:add(tether, tvb(), "Romi")
  if line:sub(1, 1) ~= "#" then
    t:add_proto_expert_info(e.malformed, "Romi frame without its '#'")
    pinfo.cols.info:append("malformed " .. printable(line))
    return
  end
  local colon = line:match(".*():")  -- the last ':' (log text may contain ':')
  if not colon then
    t:add_proto_expert_info(e.malformed, "Romi frame without its ':' metadata")
    pinfo.cols.info:append("malformed " .. printable(line))
    return
  end
  local meta = line:sub(colon + 1)
  local summary

  if line:sub(2, 2) == "!" then
    local text = line:sub(3, colon - 1)
    t:add(f.romi_kind, tvb(0, 2), "log")
    t:add(f.romi_log, tvb(2, colon - 3), printable(text))
    if meta ~= "xxxx" then t:add_proto_expert_info(e.malformed, "log line metadata is not 'xxxx'") end
    pinfo.cols.info:append("log: " .. printable(text))
    return
  end

  local payload = line:sub(2, colon - 1)
  local manual = meta == "xxxx"
  local kind
  if manual then kind = "manual request"
  elseif direction == 2 then kind = "request"
  else kind = "response" end
  t:add(f.romi_kind, tvb(0, 1), kind)

  local opcode = payload:sub(1, 1)
  if opcode ~= "" then t:add(f.romi_opcode, tvb(1, 1), printable(opcode)) end
  local args_text = payload:sub(2)
  local values = {}
  if args_text ~= "" then
    local inner = args_text:match("^%[(.*)%]$")
    if not inner then
      t:add_proto_expert_info(e.malformed, "arguments not in [...]")
    else
      local args_item = t:add(f.romi_args, tvb(2, #args_text), printable(args_text))
      values = split_values(inner, 3)
      if kind == "response" then
        local first = values[1]
        local code = first and tonumber(first[1])
        if not code or code ~= math.floor(code) then
          args_item:add_proto_expert_info(e.malformed, "response without an integer code first")
        else
          args_item:add(f.romi_code, tvb(first[2], #first[1]), code)
          local meaning
          if code > 0 then meaning = "application error " .. code else meaning = romi_errors[code] or "unknown error" end
          if code ~= 0 then
            args_item:add(f.romi_error, tvb(first[2], #first[1]), meaning)
            args_item:add_proto_expert_info(e.error_reply, "error " .. code .. ": " .. meaning)
          end
          for i = 2, #values do
            args_item:add(f.romi_value, tvb(values[i][2], #values[i][1]), printable(values[i][1]))
          end
          summary = code == 0 and "ok" or ("error " .. code .. " " .. meaning)
        end
      else
        for i = 1, #values do
          args_item:add(f.romi_arg, tvb(values[i][2], #values[i][1]), printable(values[i][1]))
        end
      end
    end
  end

  local id
  if not manual then
    local id_text, crc_text = meta:match("^(%x%x)(%x%x)$")
    if not id_text or meta:find("%u") then
      t:add_proto_expert_info(e.malformed, "metadata '" .. printable(meta) .. "' is not two lowercase hex bytes")
    else
      id = tonumber(id_text, 16)
      local crc = tonumber(crc_text, 16)
      local computed = crc8_smbus(line, 1, colon + 2)
      t:add(f.romi_id, tvb(colon, 2), id)
      local crc_item = t:add(f.romi_crc, tvb(colon + 2, 2), crc)
      crc_item:add(f.romi_crc_computed, tvb(colon + 2, 2), computed):set_generated()
      crc_item:add(f.romi_crc_status, tvb(colon + 2, 2), crc == computed and CK_GOOD or CK_BAD):set_generated()
      if crc ~= computed then
        crc_item:add_proto_expert_info(e.bad_crc, string.format("CRC-8 %02x, computed %02x", crc, computed))
        summary = (summary and summary .. " " or "") .. "[bad CRC]"
      end
    end
  end

  show_links(pinfo, t, tvb)

  local info = kind .. " " .. printable(payload)
  if id then info = info .. " id=" .. id end
  if summary then info = info .. " " .. summary end
  pinfo.cols.info:append(info)
end

-------------------------------------------------------------------------------------------------------------
-- Protobuf, just enough to read the envelopes' ids (the fields are shown by Wireshark's protobuf dissector)

-- Varint at position i (1-based) of s: value, next position; nil when truncated. Values up to 2^53.
local function read_varint(s, i)
  local value, scale = 0, 1
  while i <= #s do
    local b = s:byte(i)
    value = value + band(b, 0x7F) * scale
    i = i + 1
    if b < 0x80 then return value, i end
    scale = scale * 128
    if scale > 2 ^ 56 then return nil end
  end
  return nil
end

-- Fields of message bytes s: list of { number =, wire =, value = (varint) or from/to (length-delimited) }.
local function read_fields(s)
  local fields, i = {}, 1
  while i <= #s do
    local key
    key, i = read_varint(s, i)
    if not key then return fields, false end
    local number, wire = math.floor(key / 8), key % 8
    local field = { number = number, wire = wire }
    if wire == 0 then
      field.value, i = read_varint(s, i)
      if not field.value then return fields, false end
    elseif wire == 2 then
      local length
      length, i = read_varint(s, i)
      if not length or i + length - 1 > #s then return fields, false end
      field.from, field.to = i, i + length - 1
      i = i + length
    elseif wire == 1 then i = i + 8
    elseif wire == 5 then i = i + 4
    else return fields, false end
    if i > #s + 1 then return fields, false end
    fields[#fields + 1] = field
  end
  return fields, true
end

local function field_of(fields, number)
  for _, field in ipairs(fields) do
    if field.number == number then return field end
  end
  return nil
end

local function varint_of(s, number)
  local fields = read_fields(s)
  local field = field_of(fields, number)
  return field and field.wire == 0 and field.value or 0
end

-- Hands bytes to Wireshark's protobuf dissector as message `type_name` (needs the .proto in its search path).
local function call_protobuf(tvb, pinfo, tree, type_name)
  if not protobuf then
    data_dissector:call(tvb, pinfo, tree)
    return
  end
  pinfo.private["pb_msg_type"] = "message," .. type_name
  -- The Info column stays ours (the protobuf dissector would append "(PROTOBUF) <type>" per call).
  local info = tostring(pinfo.cols.info)
  local ok = pcall(Dissector.call, protobuf, tvb, pinfo, tree)
  if not ok then data_dissector:call(tvb, pinfo, tree) end
  pinfo.cols.info = info
end

-------------------------------------------------------------------------------------------------------------
-- COBS frames (proxy, proxy-compat, rpc): [0x00] COBS([crc16 LE] payload) 0x00

-- Decodes one COBS frame (no delimiter): the bytes, or nil and why.
local function cobs_decode(s)
  local out, i = {}, 1
  while i <= #s do
    local code = s:byte(i)
    if code == 0 then return nil, "0x00 inside the frame" end
    if i + code - 1 > #s then return nil, "code byte runs past the end" end
    out[#out + 1] = s:sub(i + 1, i + code - 1)
    i = i + code
    if code < 0xFF and i <= #s then out[#out + 1] = "\0" end
  end
  return table.concat(out)
end

-- Undoes the framing and checks the CRC: the payload as a new Tvb, or nil (already reported).
local function dissect_cobs(tvb, pinfo, t, with_crc)
  local raw = tvb:raw()
  local first = 1
  while first <= #raw and raw:byte(first) == 0 do first = first + 1 end
  local last = #raw
  if last >= first and raw:byte(last) == 0 then last = last - 1 end
  if first > 1 and first <= last then t:add(f.cobs_delimiter, tvb(0, first - 1)) end
  if first > last then
    t:add(f.message, tvb(), "empty frame (a delimiter)")
    pinfo.cols.info:append("empty frame")
    return nil
  end
  if raw:byte(#raw) ~= 0 then
    t:add_proto_expert_info(e.malformed, "frame without its 0x00 delimiter")
  end
  local decoded, why = cobs_decode(raw:sub(first, last))
  if not decoded then
    t:add_proto_expert_info(e.malformed, "bad COBS: " .. why)
    pinfo.cols.info:append("bad COBS")
    return nil
  end
  local payload_tvb = ByteArray.new(decoded, true):tvb("COBS decoded")
  t:add(f.cobs_length, tvb(first - 1, last - first + 1), #decoded):set_generated()
  if with_crc then
    if #decoded < 2 then
      t:add_proto_expert_info(e.malformed, "frame too short for its CRC-16")
      pinfo.cols.info:append("too short")
      return nil
    end
    local crc = decoded:byte(1) + 256 * decoded:byte(2)
    local computed = crc16_mcrf4xx(decoded, 3, #decoded)
    local crc_item = t:add(f.crc16, payload_tvb(0, 2), crc)
    crc_item:add(f.crc16_computed, payload_tvb(0, 2), computed):set_generated()
    crc_item:add(f.crc16_status, payload_tvb(0, 2), crc == computed and CK_GOOD or CK_BAD):set_generated()
    if crc ~= computed then
      crc_item:add_proto_expert_info(e.bad_crc, string.format("CRC-16 %04x, computed %04x", crc, computed))
      pinfo.cols.info:append("[bad CRC] ")
    end
    if #decoded == 2 then return ByteArray.new("", true):tvb("payload"), "", crc ~= computed end
    return payload_tvb(2):tvb(), decoded:sub(3), crc ~= computed
  end
  return payload_tvb, decoded, false
end

local proxy_in_names = { [2] = "ping", [3] = "servoInit", [4] = "servoControl", [5] = "digitalInit",
  [6] = "digitalControl", [7] = "reset", [8] = "pingFailsafeReset" }
local proxy_out_names = { [1] = "ack", [2] = "error", [3] = "info", [4] = "resetEvent", [5] = "pinState" }
local compat_in_names = { [1] = "servoInit", [2] = "servoControl", [3] = "digitalInit", [4] = "digitalControl",
  [5] = "reset", [6] = "dcMotorInit", [7] = "dcMotorControl", [8] = "stepperMotorControl" }
local compat_out_names = { [1] = "eventMessage", [2] = "errorMessage", [3] = "servoState", [4] = "digitalState",
  [5] = "dcMotorState", [6] = "stepperMotorState", [7] = "loadCellState" }

-- The oneof member present: its name and field.
local function oneof_of(fields, names)
  for _, field in ipairs(fields) do
    if names[field.number] then return names[field.number], field end
  end
  return nil
end

local function dissect_proxy(tvb, pinfo, tree, link, direction)
  local compat = link.codec == "proxy-compat"
  local with_crc
  if link.crc then with_crc = link.crc == "on" else with_crc = not compat end
  local t = tree:add(tether, tvb(), compat and "proxy (compatibility mode)" or "proxy")
  local payload_tvb, payload, bad_crc = dissect_cobs(tvb, pinfo, t, with_crc)
  if not payload_tvb then return end
  local package = compat and "RocketryProto" or "tether.proxy"
  local type_name = package .. (direction == 2 and ".ArduinoIn" or ".ArduinoOut")
  t:add(f.message, tvb(), type_name):set_generated()
  local fields, complete = read_fields(payload)
  if not complete then t:add_proto_expert_info(e.malformed, "payload is not a complete protobuf message") end
  local info
  if direction == 2 then
    local name = oneof_of(fields, compat and compat_in_names or proxy_in_names)
    info = name or "ArduinoIn"
    if not compat then
      local id_field = field_of(fields, 1)
      local id = id_field and id_field.wire == 0 and id_field.value or 0
      t:add(f.message_id, tvb(), id):set_generated()
      info = info .. " id=" .. id
    end
  else
    local name, member = oneof_of(fields, compat and compat_out_names or proxy_out_names)
    info = name or "ArduinoOut"
    if not compat and name == "ack" and member.wire == 2 then
      local ack = payload:sub(member.from, member.to)
      local id = varint_of(ack, 1)
      local refused = varint_of(ack, 3) ~= 0
      t:add(f.acked_id, tvb(), id):set_generated()
      t:add(f.refused, tvb(), refused):set_generated()
      if refused then t:add_proto_expert_info(e.refused, "message " .. id .. " refused") end
      info = info .. " id=" .. id .. (refused and " refused" or "")
    end
  end
  show_links(pinfo, t, tvb, true)
  pinfo.cols.info:append(info)
  call_protobuf(payload_tvb, pinfo, tree, type_name)
end

-------------------------------------------------------------------------------------------------------------
-- rpc: the proxy's framing around tether.rpc.wire.HostMessage / DeviceMessage; method messages by the schema

-- Strips // and /* */ comments and string literals' contents that could hold braces.
local function strip_proto_comments(text)
  text = text:gsub("/%*.-%*/", " ")
  text = text:gsub("//[^\n]*", "")
  return text
end

-- Reads `schema` (a file name as the capture gives it): { package =, methods = { [index] = {name, input,
-- output, streaming} } } or nil. The types' full names are looked up by Wireshark's protobuf dissector.
local function load_schema(name)
  if schemas[name] ~= nil then return schemas[name] or nil end
  local candidates = { name }
  local base_name = name:match("([^/]+)$")
  for dir in tether.prefs.schema_dirs:gmatch("[^:]+") do
    candidates[#candidates + 1] = dir .. "/" .. name
    candidates[#candidates + 1] = dir .. "/" .. base_name
  end
  local text
  for _, path in ipairs(candidates) do
    local file = io.open(path, "r")
    if file then
      text = file:read("*a")
      file:close()
      break
    end
  end
  if not text then
    schemas[name] = false
    return nil
  end
  text = strip_proto_comments(text)
  local schema = { package = text:match("package%s+([%w_%.]+)%s*;") or "", methods = {} }
  local declared = {}
  for name in text:gmatch("message%s+([%w_]+)") do declared[name] = true end
  for name in text:gmatch("enum%s+([%w_]+)") do declared[name] = true end
  local service = text:match("service%s+[%w_]+%s*(%b{})")
  if service then
    local index = 0
    for method, input, stream, output in service:gmatch(
        "rpc%s+([%w_]+)%s*%(%s*([%w_%.]+)%s*%)%s*returns%s*%(%s*(s?t?r?e?a?m?)%s*([%w_%.]+)%s*%)") do
      -- Protobuf's scoping, simplified: a name whose first part is a message or enum of this file is the
      -- package's; another dotted name is already full (an import's, `google.protobuf.Empty`).
      local function qualify(type_name)
        if type_name:sub(1, 1) == "." then return type_name:sub(2) end
        local first = type_name:match("^([%w_]+)")
        local own = type_name:find(".", 1, true) == nil or declared[first]
        if own and schema.package ~= "" then return schema.package .. "." .. type_name end
        return type_name
      end
      schema.methods[index] = { name = method, input = qualify(input), output = qualify(output),
        streaming = stream == "stream" }
      index = index + 1
    end
  end
  schemas[name] = schema
  return schema
end

local host_body_names = { [2] = "hello", [3] = "call", [4] = "open", [5] = "close", [6] = "ping", [7] = "reset" }
local device_body_names = { [1] = "ack", [2] = "reply", [3] = "error", [4] = "stream", [5] = "hello", [6] = "reset" }

local function dissect_rpc(tvb, pinfo, tree, link, direction)
  local with_crc = link.crc ~= "off"
  local t = tree:add(tether, tvb(), "rpc")
  local payload_tvb, payload, bad_crc = dissect_cobs(tvb, pinfo, t, with_crc)
  if not payload_tvb then return end
  local type_name = "tether.rpc.wire." .. (direction == 2 and "HostMessage" or "DeviceMessage")
  t:add(f.message, tvb(), type_name):set_generated()
  local fields, complete = read_fields(payload)
  if not complete then t:add_proto_expert_info(e.malformed, "payload is not a complete protobuf message") end
  local schema = link.schema and load_schema(link.schema)
  if link.schema and not schema then
    t:add_proto_expert_info(e.no_schema, "schema " .. link.schema .. " not found (Tether preferences: rpc schema folders)")
  end
  local inner  -- { from, to, type } of the method message inside the envelope
  local info

  local function method_item(index)
    t:add(f.rpc_method_index, tvb(), index):set_generated()
    local method = schema and schema.methods[index]
    if method then t:add(f.rpc_method, tvb(), method.name):set_generated() end
    return method
  end

  if direction == 2 then
    local name, body = oneof_of(fields, host_body_names)
    local id = varint_of(payload, 1)
    t:add(f.message_id, tvb(), id):set_generated()
    info = (name or "HostMessage") .. " id=" .. id
    if (name == "call" or name == "open") and body.wire == 2 then
      local body_bytes = payload:sub(body.from, body.to)
      local index = varint_of(body_bytes, 1)
      local method = method_item(index)
      info = info .. " " .. (method and method.name or ("method " .. index))
      local request = field_of(read_fields(body_bytes), 2)
      if method and request and request.wire == 2 then
        inner = { body.from + request.from - 1, body.from + request.to - 1, method.input }
      end
    end
  else
    local name, body = oneof_of(fields, device_body_names)
    info = name or "DeviceMessage"
    local body_bytes = body and body.wire == 2 and payload:sub(body.from, body.to) or ""
    if name == "ack" then
      local id = varint_of(body_bytes, 1)
      local refused = varint_of(body_bytes, 2) ~= 0
      t:add(f.acked_id, tvb(), id):set_generated()
      t:add(f.refused, tvb(), refused):set_generated()
      if refused then t:add_proto_expert_info(e.refused, "message " .. id .. " refused") end
      info = info .. " id=" .. id .. (refused and " refused" or "")
    elseif name == "reply" or name == "error" then
      local call = varint_of(body_bytes, 1)
      t:add(f.rpc_call, tvb(), call):set_generated()
      info = info .. " call=" .. call
      local index = linked[pinfo.number] and linked[pinfo.number].method
      local method = index and method_item(index)
      if method then info = info .. " " .. method.name end
      if name == "error" then
        local code = varint_of(body_bytes, 2)
        local meaning = rpc_errors[code] or (code < 0xFF00 and "application error" or "unknown error")
        t:add(f.rpc_code, tvb(), code):set_generated()
        t:add(f.rpc_error, tvb(), meaning):set_generated()
        t:add_proto_expert_info(e.error_reply, "error " .. code .. ": " .. meaning)
        info = info .. " error " .. code .. " " .. meaning
      else
        local reply = field_of(read_fields(body_bytes), 2)
        if method and reply and reply.wire == 2 then
          inner = { body.from + reply.from - 1, body.from + reply.to - 1, method.output }
        elseif method and not reply then
          inner = { body.to + 1, body.to, method.output }  -- an empty reply: every field at its default
        end
      end
    elseif name == "stream" then
      local stream = varint_of(body_bytes, 1)
      local seq = varint_of(body_bytes, 2)
      t:add(f.rpc_stream, tvb(), stream):set_generated()
      t:add(f.rpc_seq, tvb(), seq):set_generated()
      info = info .. " stream=" .. stream .. " seq=" .. seq
      local index = linked[pinfo.number] and linked[pinfo.number].method
      local method = index and method_item(index)
      if method then info = info .. " " .. method.name end
      local message = field_of(read_fields(body_bytes), 3)
      if method and message and message.wire == 2 then
        inner = { body.from + message.from - 1, body.from + message.to - 1, method.output }
      end
    end
  end
  show_links(pinfo, t, tvb)
  pinfo.cols.info:append(info)
  call_protobuf(payload_tvb, pinfo, tree, type_name)
  if inner then
    t:add(f.rpc_type, tvb(), inner[3]):set_generated()
    local inner_tvb = ByteArray.new(payload:sub(inner[1], inner[2]), true):tvb(inner[3])
    call_protobuf(inner_tvb, pinfo, tree, inner[3])
  end
end

-------------------------------------------------------------------------------------------------------------
-- Elcano: `D{s 50}{a 25}\n` (generation B), `D{s50}{a25}74\n` (generation D: decimal CRC-8 trailer)

local elcano_fields = { n = f.elcano_number, s = f.elcano_speed, a = f.elcano_angle, o = f.elcano_obstacle,
  b = f.elcano_bearing, r = f.elcano_probability, p = f.elcano_east, q = f.elcano_north }
local elcano_required = { D = "sa", S = "sapb", G = "npb", X = "npbs" }
local UNSET = 2147483647

local function dissect_elcano(tvb, pinfo, tree, link, direction)
  local raw = tvb:raw()
  local generation = (link.generation or "B"):upper()
  local t = tree:add(tether, tvb(), "Elcano")
  t:add(f.elcano_generation, tvb(0, 0), generation):set_generated()
  local function fail(why)
    why = printable(why)
    t:add(f.elcano_error, tvb(), why)
    t:add_proto_expert_info(e.malformed, why)
    pinfo.cols.info:append("malformed: " .. why)
  end
  -- Offsets of the bytes that count (whitespace is ignored anywhere, also inside numbers).
  local chars, offsets = {}, {}
  for i = 1, #raw do
    local c = raw:sub(i, i)
    if c ~= " " and c ~= "\t" and c ~= "\r" and c ~= "\0" and c ~= "\n" then
      chars[#chars + 1] = c
      offsets[#offsets + 1] = i - 1
    end
  end
  local s = table.concat(chars)
  local header = s:sub(1, 1)
  if not elcano_types[header] then return fail("bad_type: header '" .. header .. "'") end
  t:add(f.elcano_type, tvb(offsets[1], 1), header .. " (" .. elcano_types[header] .. ")")
  local i, seen, values = 2, {}, {}
  local last_brace = 1
  while i <= #s and s:sub(i, i) == "{" do
    local close = s:find("}", i, true)
    if not close then return fail("bad_lcurly: attribute without its '}'") end
    local letter, number = s:sub(i + 1, i + 1), s:sub(i + 2, close - 1)
    local from, to = offsets[i], offsets[close]
    local range = tvb(from, to - from + 1)
    local list = { number }
    if letter == "p" and generation ~= "D" then
      local east, north = number:match("^(.-),(.*)$")
      if not east then return fail("bad_number: {p E,N} without its ','") end
      list = { east, north }
    end
    local parsed = {}
    for k, text in ipairs(list) do
      if not text:match("^%-?%d+$") then return fail("bad_number: '" .. text .. "' in {" .. letter .. "}") end
      local value = tonumber(text)
      if value > 2147483647 or value < -2147483648 then return fail("bad_number: " .. text .. " out of int32") end
      parsed[k] = value
    end
    local field = elcano_fields[letter]
    if not field or (generation ~= "D" and (letter == "o" or letter == "q")) then
      return fail("bad_attrib: {" .. letter .. "}")
    end
    if letter == "p" and generation ~= "D" then
      if parsed[1] ~= UNSET then t:add(f.elcano_east, range, parsed[1]); seen.p = true end
      if parsed[2] ~= UNSET then t:add(f.elcano_north, range, parsed[2]) end
    elseif parsed[1] ~= UNSET then
      t:add(field, range, parsed[1])
      seen[letter] = true
    end
    values[letter] = parsed[1]
    last_brace = close
    i = close + 1
  end
  local trailer = s:sub(i)
  if generation == "D" then
    if not trailer:match("^%d+$") then return fail("bad_crc: no decimal CRC after the last '}'") end
    local crc = tonumber(trailer)
    local computed = crc8_smbus(s, 1, last_brace)
    local from = offsets[i]
    local crc_item = t:add(f.elcano_crc, tvb(from, offsets[#s] - from + 1), crc)
    crc_item:add(f.elcano_crc_computed, tvb(from, offsets[#s] - from + 1), computed):set_generated()
    crc_item:add(f.elcano_crc_status, tvb(from, offsets[#s] - from + 1), crc == computed and CK_GOOD or CK_BAD)
      :set_generated()
    if crc ~= computed then
      crc_item:add_proto_expert_info(e.bad_crc, string.format("CRC-8 %d, computed %d", crc, computed))
      pinfo.cols.info:append("[bad CRC] ")
    end
  elseif trailer ~= "" then
    return fail("bad_lcurly: '" .. trailer .. "' after the attributes")
  end
  if raw:byte(#raw) ~= 10 then t:add_proto_expert_info(e.malformed, "message without its '\\n'") end
  local missing = {}
  for letter in elcano_required[header]:gmatch(".") do
    if generation == "D" and letter == "p" and not seen.q then missing[#missing + 1] = "q" end
    if not seen[letter] then missing[#missing + 1] = letter end
  end
  if #missing > 0 then
    t:add(f.elcano_error, tvb(), "inval_comb: missing " .. table.concat(missing, " "))
    t:add_proto_expert_info(e.malformed, "inval_comb: " .. elcano_types[header] .. " without " .. table.concat(missing, " "))
  end
  pinfo.cols.info:append(elcano_types[header] .. " " .. printable(s))
end

-------------------------------------------------------------------------------------------------------------
-- Requests and answers, linked on the first pass over the file
--
-- Wireshark's first pass may run without a protocol tree (tshark -2 without a read filter, Wireshark
-- loading a file), and then the interface's fields are not available: the codec is then told by the bytes
-- (Romi `#`, a COBS frame's 0x00) and every link shares one table. Only frames whose check passes count.

-- The COBS payload of `raw` with its CRC-16 checked and removed (`crc` true), or as it is (`crc` false); nil
-- for a frame that must not count.
local function checked_payload(raw, crc)
  local first, last = 1, #raw
  while first <= last and raw:byte(first) == 0 do first = first + 1 end
  if last < first or raw:byte(last) ~= 0 then return nil end
  local decoded = cobs_decode(raw:sub(first, last - 1))
  if not decoded or #decoded == 0 then return nil end
  if crc == false then return decoded end
  if #decoded >= 2 and decoded:byte(1) + 256 * decoded:byte(2) == crc16_mcrf4xx(decoded, 3, #decoded) then
    return decoded:sub(3)
  end
  return nil
end

-- Records frame `pinfo.number` of link `iface` (`codec`: a codec name, or "cobs" when told by the bytes).
local function bookkeep(pinfo, iface, codec, link, direction, raw)
  if codec == "romi" then
    local line = raw:match("^(#[^\r\n]*)\r?\n?$")
    if not line or line:sub(2, 2) == "!" then return end
    local colon = line:match(".*():")
    if not colon then return end
    local meta = line:sub(colon + 1)
    if meta == "xxxx" then
      if direction == 2 then note_request(pinfo, iface .. ":manual", raw) end
      return
    end
    local id_text, crc_text = meta:match("^([0-9a-f][0-9a-f])([0-9a-f][0-9a-f])$")
    if not id_text or tonumber(crc_text, 16) ~= crc8_smbus(line, 1, colon + 2) then return end
    local id = tonumber(id_text, 16)
    if direction == 2 then
      note_request(pinfo, iface .. ":" .. id, raw, 2.0)  -- the host's call budget
    elseif direction == 1 then
      local manual = pending[iface .. ":manual"]
      if id == 0 and manual and not manual.answered then
        note_answer(pinfo, iface .. ":manual", "response")
      else
        note_answer(pinfo, iface .. ":" .. id, "response")
      end
    end
    return
  end
  if codec ~= "proxy" and codec ~= "rpc" and codec ~= "cobs" then return end
  -- Told by the bytes, only a frame with a good CRC-16 counts: proxy-compat's frames have none, and their
  -- messages (an EventMessage reads as an ack) are not requests and answers.
  local crc = true
  if codec ~= "cobs" then crc = link.crc ~= "off" end
  local payload = checked_payload(raw, crc)
  if not payload then return end
  local fields = read_fields(payload)
  if direction == 2 then
    local id = varint_of(payload, 1)
    note_request(pinfo, iface .. ":" .. id, payload)
    if codec ~= "proxy" then
      -- An rpc call or stream: its method, for the answers' message types.
      local body = field_of(fields, 3) or field_of(fields, 4)
      if body and body.wire == 2 then
        local index = varint_of(payload:sub(body.from, body.to), 1)
        link_of(pinfo.number).method = index
        pending[iface .. ":" .. id].method = index
      end
    end
  elseif direction == 1 then
    local first = fields[1]
    if not first or first.wire ~= 2 then return end
    local body = payload:sub(first.from, first.to)
    if first.number == 1 then  -- an ack (both envelopes): the proxy's answer, the rpc's receipt
      note_answer(pinfo, iface .. ":" .. varint_of(body, 1), "ack", codec == "proxy")
    elseif codec ~= "proxy" and (first.number == 2 or first.number == 3 or first.number == 4) then
      local inner = read_fields(body)
      if not inner[1] or inner[1].wire ~= 0 then return end  -- a proxy Error's text, not an rpc call id
      local key = iface .. ":" .. varint_of(body, 1)
      local request = pending[key]
      if first.number == 4 then  -- a stream message: no answer, the method of its stream
        if request and request.method then link_of(pinfo.number).method = request.method end
        return
      end
      request = note_answer(pinfo, key, "response")
      if request and request.method then link_of(pinfo.number).method = request.method end
    end
  end
end

-------------------------------------------------------------------------------------------------------------
-- The packet

local codecs = { romi = dissect_romi, proxy = dissect_proxy, ["proxy-compat"] = dissect_proxy, rpc = dissect_rpc,
  elcano = dissect_elcano }

local function is_text(s)
  return not s:find("[^\9\10\13\32-\126]")
end

function tether.dissector(tvb, pinfo, tree)
  local description = fx_description()
  if not description then
    -- A pass without a protocol tree: nothing to show, only the first pass's bookkeeping (by the bytes).
    if not pinfo.visited and tvb:len() > 0 then
      local raw = tvb:raw()
      local direction = pinfo.p2p_dir == 0 and 2 or pinfo.p2p_dir == 1 and 1 or 0
      local codec = raw:sub(1, 1) == "#" and "romi" or raw:byte(#raw) == 0 and "cobs" or nil
      if codec then bookkeep(pinfo, "?", codec, {}, direction, raw) end
    end
    return
  end
  local link = parse_description(description.value)
  if not link then
    local t = tree:add(tether, tvb(), "Tether (not a Tether link)")
    t:add_proto_expert_info(e.not_tether, "interface description does not start with 'tether'")
    data_dissector:call(tvb, pinfo, tree)
    return
  end
  local interface = fx_interface()
  link.interface = interface and interface.value or 0
  local name = fx_name()
  local dir = fx_direction()
  local direction = dir and dir.value or 0

  pinfo.cols.protocol = "Tether/" .. (link.codec or "?")
  local t = tree:add(tether, tvb(), "Tether link")
  t:add(f.device, tvb(0, 0), name and name.value or ""):set_generated()
  t:add(f.codec, tvb(0, 0), link.codec or ""):set_generated()
  if link.baud then t:add(f.baud, tvb(0, 0), link.baud):set_generated() end
  if link.transport then t:add(f.transport, tvb(0, 0), link.transport):set_generated() end
  t:add(f.direction, tvb(0, 0), direction):set_generated()
  pinfo.cols.info = (name and name.value or "?") .. ": "
  if direction == 1 then
    pinfo.cols.src = name and name.value or "device"
    pinfo.cols.dst = "host"
  elseif direction == 2 then
    pinfo.cols.src = "host"
    pinfo.cols.dst = name and name.value or "device"
  end

  -- Packets that are no frame: unframed bytes and link events (their comment says which).
  for _, comment in ipairs({ fx_comment() }) do
    local text = comment.value
    if text:sub(1, 8) == "unframed" then
      local reason = text:match("^unframed:%s*(.*)$") or ""
      t:add(f.unframed, tvb(), reason)
      t:add_proto_expert_info(e.unframed, tvb:len() .. " bytes that formed no frame"
        .. (reason ~= "" and " (" .. reason .. ")" or ""))
      local raw = tvb:raw()
      if #raw > 0 and is_text(raw) then t:add(f.text, tvb(), raw) end
      pinfo.cols.info:append("unframed (" .. (reason ~= "" and reason or "no reason") .. ") " .. tvb:len() .. " bytes")
      if tvb:len() > 0 then data_dissector:call(tvb, pinfo, tree) end
      return
    elseif text:sub(1, 6) == "link: " then
      t:add(f.link_event, tvb(0, 0), text:sub(7))
      t:add_proto_expert_info(e.link_event, "link event: " .. text:sub(7))
      pinfo.cols.info:append(text)
      return
    end
  end
  if tvb:len() == 0 then
    pinfo.cols.info:append("empty packet")
    return
  end
  if not pinfo.visited then bookkeep(pinfo, tostring(link.interface), link.codec, link, direction, tvb:raw()) end

  local dissect = codecs[link.codec or ""]
  if dissect then
    dissect(tvb, pinfo, tree, link, direction)
  else
    local raw = tvb:raw()
    if is_text(raw) then t:add(f.text, tvb(), raw) end
    pinfo.cols.info:append("codec " .. (link.codec or "?") .. ", " .. tvb:len() .. " bytes")
    data_dissector:call(tvb, pinfo, tree)
  end
end

DissectorTable.get("wtap_encap"):add(wtap_encaps.USER0, tether)
