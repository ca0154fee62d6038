"""The fixed part of the generated Wireshark dissector: Lua that walks the tables.

:mod:`fw1394.capture.views.lua_dissector` writes the tables (layouts, framing, names) above
this code; nothing here knows where any field sits.
"""

RUNTIME = r"""
-- Bit operations for Lua 5.2 (bit32) and 5.3+ (operators, loaded as text so 5.2 parses).
local band, rshift, bxor, lshift
if bit32 then
  band, rshift, bxor, lshift = bit32.band, bit32.rshift, bit32.bxor, bit32.lshift
else
  band = load("return function(a, b) return a & b end")()
  rshift = load("return function(a, n) return (a & 0xFFFFFFFF) >> n end")()
  bxor = load("return function(a, b) return (a ~ b) & 0xFFFFFFFF end")()
  lshift = load("return function(a, n) return (a << n) & 0xFFFFFFFF end")()
end

local E = {}  -- fields of the eth1394 protocol
local special = {
  record_type = record_type_names, speed = speed_names, ack = ack_names,
  ["flags.direction"] = direction_names,
}
local function declare(into, rows, prefix, names)
  for _, row in ipairs(rows) do
    into[row[1]] = ProtoField.uint32(prefix .. row[6], row[6], base.DEC, names[row[6]])
  end
end
declare(F, PSEUDO_HEADER, "fw1394.ph.", special)
declare(E, CONTROL_WORD, "eth1394.control.", {})
declare(E, EXTRA_BYTES, "eth1394.extra.", {})
-- Checksum status values as Wireshark's own dissectors number them.
local CRC_STATUS = { [0] = "Bad", [1] = "Good", [2] = "Unverified" }
for _, which in ipairs({ "header_crc", "data_crc", "phy_check" }) do
  local abbrev = which == "phy_check" and "fw1394.phy.check" or ("fw1394." .. which)
  local label = which:gsub("_", " ")
  F[which .. "_status"] = ProtoField.uint8(abbrev .. ".status", label .. " status", base.DEC,
    CRC_STATUS)
  F[which .. "_valid"] = ProtoField.bool(abbrev .. ".valid", label .. " valid")
end
F.data = ProtoField.bytes("fw1394.data", "data")
F.ack_code = ProtoField.uint8("fw1394.ack", "ack", base.DEC, ack_names)
F.ack_parity = ProtoField.uint8("fw1394.ack_parity", "ack parity", base.HEX)
F.phy_check = ProtoField.uint32("fw1394.phy.check", "check quadlet", base.HEX)
F.phy_kind = ProtoField.string("fw1394.phy.kind", "PHY packet")
F.kind = ProtoField.string("fw1394.kind", "packet")
local frame_kind = frametype or {}
F.request_in = ProtoField.framenum("fw1394.request_in", "request in", base.NONE,
  frame_kind.REQUEST)
F.response_in = ProtoField.framenum("fw1394.response_in", "response in", base.NONE,
  frame_kind.RESPONSE)
F.response_time = ProtoField.relative_time("fw1394.response_time", "response time",
  "time from the request's first attempt to the response")
F.attempts = ProtoField.uint8("fw1394.attempts", "attempts", base.DEC, nil, nil,
  "request attempts, retries after busy acks included")
local list = {}
for _, field in pairs(F) do list[#list + 1] = field end
fw1394.fields = list
local eth_list = {}
for _, field in pairs(E) do eth_list[#eth_list + 1] = field end
eth1394.fields = eth_list

local X = {
  header_crc = ProtoExpert.new("fw1394.header_crc.bad", "Header CRC does not match",
    expert.group.CHECKSUM, expert.severity.ERROR),
  data_crc = ProtoExpert.new("fw1394.data_crc.bad", "Data CRC does not match",
    expert.group.CHECKSUM, expert.severity.ERROR),
  phy_check = ProtoExpert.new("fw1394.phy.check.bad", "Check quadlet is not the complement",
    expert.group.CHECKSUM, expert.severity.ERROR),
  length = ProtoExpert.new("fw1394.length.bad", "Packet length does not add up",
    expert.group.MALFORMED, expert.severity.ERROR),
  malformed = ProtoExpert.new("fw1394.malformed", "Not a packet fw1394 can read",
    expert.group.MALFORMED, expert.severity.ERROR),
  unmatched = ProtoExpert.new("fw1394.response.unmatched", "Response without a request",
    expert.group.SEQUENCE, expert.severity.WARN),
  mismatch = ProtoExpert.new("fw1394.response.tcode_mismatch",
    "Response tcode does not answer the request", expert.group.SEQUENCE, expert.severity.WARN),
  unanswered = ProtoExpert.new("fw1394.response.missing", "No response in this capture",
    expert.group.SEQUENCE, expert.severity.NOTE),
  rcode = ProtoExpert.new("fw1394.rcode.error", "Response reports an error",
    expert.group.RESPONSE_CODE, expert.severity.WARN),
  ack = ProtoExpert.new("fw1394.ack.error", "Ack reports an error",
    expert.group.RESPONSE_CODE, expert.severity.WARN),
}
local expert_list = {}
for _, item in pairs(X) do expert_list[#expert_list + 1] = item end
fw1394.experts = expert_list

-- The 1394 CRC-32 over bytes [offset, offset + length) of tvb, a byte at a time.
local function crc32(tvb, offset, length)
  local bytes = tvb:raw(offset, length)
  local crc = 0xFFFFFFFF
  for i = 1, length do
    crc = bxor(lshift(crc, 8), CRC_TABLE[bxor(rshift(crc, 24), bytes:byte(i))])
  end
  return bxor(crc, 0xFFFFFFFF)
end

-- A CRC quadlet at `at` covering [from, at), with its status and validity.
local function add_crc(tree, tvb, at, from, which, placeholder)
  local range = tvb(at, 4)
  local item = tree:add(F[which], range)
  if placeholder then
    item:append_text(" [not computed]")
    item:add(F[which .. "_status"], range, 2):set_generated()
    return
  end
  local stored, computed = range:uint(), crc32(tvb, from, at - from)
  local good = stored == computed
  item:add(F[which .. "_status"], range, good and 1 or 0):set_generated()
  item:add(F[which .. "_valid"], range, good):set_generated()
  if not good then
    item:add_proto_expert_info(X[which], string.format(
      "%s does not match: 0x%08x in the packet, 0x%08x computed",
      which == "header_crc" and "Header CRC" or "Data CRC", stored, computed))
  end
end

local function flat_value(tvb, offset, row)
  return band(rshift(tvb(offset + row[2], row[3]):uint(), row[4]), row[5])
end

local function add_flat(tree, tvb, offset, rows, fields)
  local values = {}
  for _, row in ipairs(rows) do
    local value = flat_value(tvb, offset, row)
    values[row[6]] = value
    tree:add(fields[row[1]], tvb(offset + row[2], row[3]), value)
  end
  return values
end

-- Field values of a layout: {name -> number or UInt64}, in first-appearance order.
local function layout_values(tvb, rows)
  local order, parts = {}, {}
  for _, row in ipairs(rows) do
    local name, quadlet, lsb, mask, shift = row[1], row[2], row[3], row[4], row[5]
    local piece = band(rshift(tvb(quadlet * 4, 4):uint(), lsb), mask)
    if not parts[name] then
      parts[name] = { first = quadlet, last = quadlet, pieces = {} }
      order[#order + 1] = name
    end
    local entry = parts[name]
    entry.last = quadlet
    entry.pieces[#entry.pieces + 1] = { piece, shift }
  end
  local values = {}
  for _, name in ipairs(order) do
    local entry = parts[name]
    if #entry.pieces == 1 and entry.pieces[1][2] == 0 then
      values[name] = entry.pieces[1][1]
    else
      local value = UInt64(0)
      for _, piece in ipairs(entry.pieces) do
        value = value + UInt64(piece[1]):lshift(piece[2])
      end
      values[name] = value
    end
  end
  return order, parts, values
end

local function wire_size(tvb)
  if tvb:len() < 4 then return nil end
  local layout = ASYNC[flat_value(tvb, 0, TCODE)]
  if not layout then return nil end
  local size = 4 * (layout.quadlets + 1)
  if not layout.has_data then return size end
  if tvb:len() < size then return nil end
  local _, _, values = layout_values(tvb, layout.fields)
  local length = values.data_length
  return size + 4 * math.floor((length + 3) / 4) + 4
end

local function hex(value, digits)
  if type(value) == "number" then return string.format("%0" .. digits .. "x", value) end
  return value:tohex():sub(-digits)
end

-- Transactions. A request opens one under (bus generation, requester, responder, tlabel);
-- the first response with the same key answers it, the way fw1394's transaction view pairs
-- them: a request repeated after a busy ack is another attempt of the same transaction, an
-- ack_complete or error ack closes it unanswered, a bus reset starts a new generation. The
-- links are found on the first, in-order pass and kept per frame for later passes.
local state
local function reset_state()
  state = { open = {}, frames = {}, epoch = 0, last = nil }
end
reset_state()
fw1394.init = reset_state
eth1394.init = reset_state

local function tx_key(requester, responder, tlabel)
  return state.epoch .. ":" .. requester .. ":" .. responder .. ":" .. tlabel
end

local function set_ack(tx, ack)
  tx.ack = ack
  if (ERROR_ACKS[ack] or ack == ACK_COMPLETE) and state.open[tx.key] == tx then
    state.open[tx.key] = nil
    tx.closed = true
  end
end

local function track_request(pinfo, values, tcode, ack)
  local key = tx_key(values.src_id, values.dst_id, values.tlabel)
  local tx = state.open[key]
  if tx and tx.ack and RETRY_ACKS[tx.ack] and tx.tcode == tcode then
    tx.attempts = tx.attempts + 1
    tx.frames[#tx.frames + 1] = pinfo.number
    tx.ack = nil
  else
    tx = { key = key, tcode = tcode, frames = { pinfo.number }, attempts = 1,
           first_time = pinfo.rel_ts,
           broadcast = band(values.dst_id, BROADCAST_PHY) == BROADCAST_PHY }
    state.open[key] = tx
  end
  tx.last_time = pinfo.rel_ts
  if ack then set_ack(tx, ack) end
  return { request = tx }
end

local function track_response(pinfo, values, tcode)
  local responder = values.src_id
  local key = tx_key(values.dst_id, responder, values.tlabel)
  local tx = state.open[key]
  if not tx then  -- a broadcast request, which one node answers for all
    key = tx_key(values.dst_id, responder - band(responder, BROADCAST_PHY) + BROADCAST_PHY,
      values.tlabel)
    tx = state.open[key]
  end
  if tx and pinfo.rel_ts - tx.last_time > EXPIRY_SECONDS then tx = nil end
  if not tx then return { response = true } end
  state.open[key] = nil
  tx.response = pinfo.number
  tx.response_time = pinfo.rel_ts - tx.first_time
  return { response = true, tx = tx, tcode_ok = RESPONSE_OF_REQUEST[tx.tcode] == tcode }
end

-- What this frame is to the transactions, worked out once, on the first pass.
local function track(pinfo, kind, values, tcode, ack)
  local record = state.frames[pinfo.number]
  if record or pinfo.visited then return record end
  local last = state.last
  state.last = nil
  record = {}
  if kind == "reset" then
    state.epoch = state.epoch + 1
  elseif kind == "ack" then
    if last and last.frame == pinfo.number - 1 and last.tx then set_ack(last.tx, ack) end
  elseif kind == "async" and values.src_id and values.tlabel then
    if RESPONSE_OF_REQUEST[tcode] then
      record = track_request(pinfo, values, tcode, ack)
    elseif RESPONSE_TCODES[tcode] then
      record = track_response(pinfo, values, tcode)
    end
    if ack == nil then state.last = { frame = pinfo.number, tx = record.request } end
  end
  state.frames[pinfo.number] = record
  return record
end

local function nstime(seconds)
  local whole = math.floor(seconds)
  local nanoseconds = math.floor((seconds - whole) * 1e9 + 0.5)
  if nanoseconds >= 1000000000 then whole, nanoseconds = whole + 1, nanoseconds - 1000000000 end
  return NSTime.new(whole, nanoseconds)
end

-- An open request the trace never answers: not closed by its ack, not a broadcast, not a
-- retry that gave up (busy, or no ack at all), not a write whose ack nobody saw.
local function expects_response(tx)
  if tx.closed or tx.broadcast or tx.ack == NO_ACK or (tx.ack and RETRY_ACKS[tx.ack]) then
    return false
  end
  return tx.ack ~= nil or not WRITE_TCODES[tx.tcode]
end

local function add_links(tree, pinfo, record, timed)
  if not record then return end
  local tx = record.request or record.tx
  if record.request then
    if tx.response then
      tree:add(F.response_in, tx.response):set_generated()
    elseif pinfo.visited and expects_response(tx) then
      tree:add_proto_expert_info(X.unanswered)
    end
    tree:add(F.attempts, tx.attempts):set_generated()
  elseif record.response then
    if not tx then
      tree:add_proto_expert_info(X.unmatched, "Response without a request: no open request "
        .. "of this generation has its source, destination and tlabel")
      return
    end
    tree:add(F.request_in, tx.frames[1]):set_generated()
    if timed then tree:add(F.response_time, nstime(tx.response_time)):set_generated() end
    tree:add(F.attempts, tx.attempts):set_generated()
    if not record.tcode_ok then
      tree:add_proto_expert_info(X.mismatch, string.format(
        "Response tcode does not answer the request's %s",
        tcode_names[tx.tcode] or tx.tcode))
    end
  end
end

-- An asynchronous packet; returns a one-line summary and its field values.
-- crc: "present", "placeholder" (CRC quadlets never computed) or nil.
local function add_async(tvb, tree, crc, partial, zero_crc_unset)
  local length = tvb:len()
  if length < 4 then
    tree:add_proto_expert_info(X.length, "Shorter than one quadlet")
    return "short packet"
  end
  local tcode = flat_value(tvb, 0, TCODE)
  local layout = ASYNC[tcode]
  if not layout then
    tree:add_proto_expert_info(X.malformed, string.format("tcode 0x%x has no packet layout", tcode))
    return string.format("tcode 0x%x", tcode)
  end
  local header = 4 * layout.quadlets
  if length < header then
    tree:add_proto_expert_info(X.length, "Truncated header")
    return layout.name .. " [truncated]"
  end
  tree:add(F.kind, tvb(0, header), layout.name)
  local order, parts, values = layout_values(tvb, layout.fields)
  for _, name in ipairs(order) do
    local entry = parts[name]
    local range = tvb(entry.first * 4, (entry.last - entry.first + 1) * 4)
    if WIDE[name] then
      tree:add(F[name], range, values[name], name .. ": 0x" .. hex(values[name], WIDE[name]))
    else
      tree:add(F[name], range, values[name])
    end
  end
  local function placeholder(at)
    return crc == "placeholder" or (zero_crc_unset and tvb(at, 4):uint() == 0)
  end
  local at = header
  if crc and length >= at + 4 then
    add_crc(tree, tvb, at, 0, "header_crc", placeholder(at))
    at = at + 4
  end
  if layout.has_data and values.data_length then
    local wanted = 4 * math.floor((values.data_length + 3) / 4)
    local present = math.min(wanted, length - at)
    if present > 0 then tree:add(F.data, tvb(at, present)) end
    if present < wanted and not partial then
      tree:add_proto_expert_info(X.length, string.format(
        "Data block of %d bytes, data_length says %d", math.max(present, 0), values.data_length))
    end
    local from = at
    at = at + math.max(present, 0)
    if crc and present == wanted and length >= at + 4 then
      add_crc(tree, tvb, at, from, "data_crc", placeholder(at))
      at = at + 4
    end
  end
  if values.rcode and values.rcode ~= 0 then
    tree:add_proto_expert_info(X.rcode, "Response code " ..
      (rcode_names[values.rcode] or values.rcode))
  end
  local text = layout.name
  if values.src_id then
    text = text .. " " .. hex(values.src_id, 4) .. " -> " .. hex(values.dst_id, 4)
    text = text .. " tl=" .. values.tlabel
  end
  if values.offset then text = text .. " offset=0x" .. hex(values.offset, 12) end
  if values.rcode then
    text = text .. " " .. (rcode_names[values.rcode] or ("rcode " .. values.rcode))
  end
  if values.quadlet_data then text = text .. " data=0x" .. hex(values.quadlet_data, 8) end
  if values.data_length then text = text .. " len=" .. values.data_length end
  return text, values, tcode
end

local function show_nodes(pinfo, values)
  if values and values.src_id then
    pinfo.cols.src = hex(values.src_id, 4)
    pinfo.cols.dst = hex(values.dst_id, 4)
  end
end

local function add_ack_code(tree, range, code)
  local item = tree:add(F.ack_code, range, code)
  if ERROR_ACKS[code] then
    item:add_proto_expert_info(X.ack, "Ack " .. (ack_names[code] or code))
  end
  return item
end

local function add_phy(tvb, tree, crc_present)
  if tvb:len() < 4 then
    tree:add_proto_expert_info(X.length, "PHY packet shorter than one quadlet")
    return "short PHY packet"
  end
  local quadlet = tvb(0, 4):uint()
  -- Kind by identifier, bits 23..22 and the 1394a type: { lsb, mask, weight } rows.
  local index = 0
  for _, bits in ipairs(PHY_KIND_BITS) do
    index = index + band(rshift(quadlet, bits[1]), bits[2]) * bits[3]
  end
  local layout = PHY[PHY_DISPATCH[index]]
  if not layout then
    tree:add_proto_expert_info(X.malformed, "Identifier 3 is not a PHY packet")
    return "PHY packet?"
  end
  tree:add(F.phy_kind, tvb(0, 4), layout.name)
  local order, parts, values = layout_values(tvb, layout.fields)
  for _, name in ipairs(order) do
    tree:add(F[name], tvb(0, 4), values[name])
  end
  if crc_present and tvb:len() >= 8 then
    local item = tree:add(F.phy_check, tvb(4, 4))
    local good = bxor(quadlet, tvb(4, 4):uint()) == 0xFFFFFFFF
    item:add(F.phy_check_status, tvb(4, 4), good and 1 or 0):set_generated()
    item:add(F.phy_check_valid, tvb(4, 4), good):set_generated()
    if not good then item:add_proto_expert_info(X.phy_check) end
  end
  local text = layout.name
  if values.phy_phy_id then text = text .. " phy_id=" .. values.phy_phy_id end
  return text
end

local function add_ack(tvb, tree)
  if tvb:len() < 1 then return "ack?" end
  local code = flat_value(tvb, 0, ACK_CODE)
  add_ack_code(tree, tvb(0, 1), code)
  tree:add(F.ack_parity, tvb(0, 1), flat_value(tvb, 0, ACK_PARITY))
  return ack_names[code] or ("ack " .. code), code
end

function fw1394.dissector(tvb, pinfo, tree)
  if tvb:len() < PSEUDO_HEADER_LENGTH then return 0 end
  if tvb(0, 1):uint() ~= PSEUDO_HEADER_VERSION then return 0 end
  local length = tvb(1, 1):uint()
  if length < PSEUDO_HEADER_LENGTH or length > tvb:len() then return 0 end
  pinfo.cols.protocol = "IEEE 1394"
  local root = tree:add(fw1394, tvb(), "IEEE 1394")
  local header_tree = root:add(fw1394, tvb(0, length), "fw1394 pseudo-header")
  local v = add_flat(header_tree, tvb, 0, PSEUDO_HEADER, F)
  local crc = nil
  if v["flags.crc_present"] == 1 then
    crc = v["flags.crc_placeholder"] == 1 and "placeholder" or "present"
  end
  local partial = v["flags.partial"] == 1
  local ack = v["flags.ack_present"] == 1 and v.ack or nil
  local packet = tvb:len() > length and tvb(length):tvb() or nil
  local kind = v.record_type
  local text, values, tcode, record
  if kind == 3 then
    text = "bus reset, generation " .. v.generation
    track(pinfo, "reset")
  elseif packet == nil then
    text = (record_type_names[kind] or "record") .. " without data"
  elseif kind == 0 then
    text, values, tcode = add_async(packet, root, crc, partial, false)
    if ack then add_ack_code(root, tvb(0, length), ack):set_generated() end
    show_nodes(pinfo, values)
    record = values and track(pinfo, "async", values, tcode, ack)
  elseif kind == 1 then
    text, ack = add_ack(packet, root)
    track(pinfo, "ack", nil, nil, ack)
  elseif kind == 2 then
    text = add_phy(packet, root, crc ~= nil)
  else
    text = "record type " .. kind
  end
  add_links(root, pinfo, record, v["flags.time_unknown"] ~= 1)
  if kind == 0 and ack then
    text = text .. "  " .. (ack_names[ack] or ("ack " .. ack))
  end
  pinfo.cols.info = text
  return tvb:len()
end

function eth1394.dissector(tvb, pinfo, tree)
  local length = tvb:len()
  local root = tree:add(eth1394, tvb(), "JHU Eth1394")
  pinfo.cols.protocol = "Eth1394"
  if length == EXTRA_SIZE then
    add_flat(root:add(eth1394, tvb(), "extra bytes"), tvb, 0, EXTRA_BYTES, E)
    pinfo.cols.info = "read dropped (extra bytes only)"
    return length
  end
  local request, response = false, false
  if length >= CONTROL_WORD_SIZE + TCODE_END then
    request = REQUEST_TCODES[flat_value(tvb, CONTROL_WORD_SIZE, TCODE)]
  end
  if length >= EXTRA_SIZE + TCODE_END then
    response = RESPONSE_TCODES[flat_value(tvb, 0, TCODE)]
  end
  if request and response then
    -- Both readings start plausibly: the one whose size adds up wins.
    if wire_size(tvb(CONTROL_WORD_SIZE):tvb()) == length - CONTROL_WORD_SIZE then
      response = nil
    elseif wire_size(tvb(0, length - EXTRA_SIZE):tvb()) == length - EXTRA_SIZE then
      request = nil
    else
      response = nil
    end
  end
  local text, values, tcode
  if request then
    add_flat(root:add(eth1394, tvb(0, CONTROL_WORD_SIZE), "control word"), tvb, 0, CONTROL_WORD, E)
    local packet_tree = tree:add(fw1394, tvb(CONTROL_WORD_SIZE), "IEEE 1394 request")
    text, values, tcode = add_async(tvb(CONTROL_WORD_SIZE):tvb(), packet_tree, "present", false,
      false)
  elseif response then
    local packet_tree = tree:add(fw1394, tvb(0, length - EXTRA_SIZE), "IEEE 1394 response")
    -- The FPGA leaves its responses' CRC quadlets zero: not computed, not wrong.
    text, values, tcode = add_async(tvb(0, length - EXTRA_SIZE):tvb(), packet_tree, "present",
      false, true)
    local extra = root:add(eth1394, tvb(length - EXTRA_SIZE, EXTRA_SIZE), "extra bytes")
    add_flat(extra, tvb, length - EXTRA_SIZE, EXTRA_BYTES, E)
  else
    text = "not an Eth1394 datagram"
  end
  if values then  -- Source and Destination keep the IP addresses; Info names the nodes
    add_links(tree, pinfo, track(pinfo, "async", values, tcode, nil), true)
  end
  pinfo.cols.info = text
  return length
end

local encaps = wtap_encaps or wtap
DissectorTable.get("wtap_encap"):add(encaps["USER" .. (LINKTYPE - 147)], fw1394)
DissectorTable.get("udp.port"):add(UDP_PORT, eth1394)
"""
