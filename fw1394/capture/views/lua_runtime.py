"""The fixed part of the generated Wireshark dissector: Lua that walks the tables.

:mod:`fw1394.capture.views.lua_dissector` writes the tables (layouts, framing, names) above
this code; nothing here knows where any field sits.
"""

RUNTIME = r"""
-- Bit operations for Lua 5.2 (bit32) and 5.3+ (operators, loaded as text so 5.2 parses).
local band, rshift, bxor
if bit32 then
  band, rshift, bxor = bit32.band, bit32.rshift, bit32.bxor
else
  band = load("return function(a, b) return a & b end")()
  rshift = load("return function(a, n) return (a & 0xFFFFFFFF) >> n end")()
  bxor = load("return function(a, b) return (a ~ b) & 0xFFFFFFFF end")()
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
F.data = ProtoField.bytes("fw1394.data", "data")
F.ack_code = ProtoField.uint8("fw1394.ack", "ack", base.DEC, ack_names)
F.ack_parity = ProtoField.uint8("fw1394.ack_parity", "ack parity", base.HEX)
F.phy_check = ProtoField.uint32("fw1394.phy.check", "check quadlet", base.HEX)
F.phy_kind = ProtoField.string("fw1394.phy.kind", "PHY packet")
F.kind = ProtoField.string("fw1394.kind", "packet")
F.problem = ProtoField.string("fw1394.problem", "problem")
local list = {}
for _, field in pairs(F) do list[#list + 1] = field end
fw1394.fields = list
local eth_list = {}
for _, field in pairs(E) do eth_list[#eth_list + 1] = field end
eth1394.fields = eth_list

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

-- An asynchronous packet; returns a one-line summary.
local function add_async(tvb, tree, crc_present, partial)
  local length = tvb:len()
  if length < 4 then
    tree:add(F.problem, "shorter than one quadlet")
    return "short packet"
  end
  local tcode = flat_value(tvb, 0, TCODE)
  local layout = ASYNC[tcode]
  if not layout then
    tree:add(F.problem, string.format("tcode 0x%x has no packet layout", tcode))
    return string.format("tcode 0x%x", tcode)
  end
  local header = 4 * layout.quadlets
  if length < header then
    tree:add(F.problem, "truncated header")
    return layout.name .. " [truncated]"
  end
  tree:add(F.kind, tvb(0, header), layout.name)
  local order, parts, values = layout_values(tvb, layout.fields)
  for _, name in ipairs(order) do
    local entry = parts[name]
    tree:add(F[name], tvb(entry.first * 4, (entry.last - entry.first + 1) * 4), values[name])
  end
  local at = header
  if crc_present and length >= at + 4 then
    tree:add(F.header_crc, tvb(at, 4))
    at = at + 4
  end
  if layout.has_data and values.data_length then
    local wanted = 4 * math.floor((values.data_length + 3) / 4)
    local present = math.min(wanted, length - at)
    if present > 0 then tree:add(F.data, tvb(at, present)) end
    if present < wanted and not partial then
      tree:add(F.problem, "data block shorter than data_length")
    end
    at = at + math.max(present, 0)
    if crc_present and length >= at + 4 then
      tree:add(F.data_crc, tvb(at, 4))
      at = at + 4
    end
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
  return text
end

local function add_phy(tvb, tree, crc_present)
  if tvb:len() < 4 then
    tree:add(F.problem, "PHY packet shorter than one quadlet")
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
    tree:add(F.problem, "identifier 3 is not a PHY packet")
    return "PHY packet?"
  end
  tree:add(F.phy_kind, tvb(0, 4), layout.name)
  local order, parts, values = layout_values(tvb, layout.fields)
  for _, name in ipairs(order) do
    tree:add(F[name], tvb(0, 4), values[name])
  end
  if crc_present and tvb:len() >= 8 then
    local item = tree:add(F.phy_check, tvb(4, 4))
    if bxor(quadlet, tvb(4, 4):uint()) ~= 0xFFFFFFFF then
      tree:add(F.problem, "check quadlet is not the complement")
    end
  end
  local text = layout.name
  if values.phy_phy_id then text = text .. " phy_id=" .. values.phy_phy_id end
  return text
end

local function add_ack(tvb, tree)
  if tvb:len() < 1 then return "ack?" end
  local code = flat_value(tvb, 0, ACK_CODE)
  tree:add(F.ack_code, tvb(0, 1), code)
  tree:add(F.ack_parity, tvb(0, 1), flat_value(tvb, 0, ACK_PARITY))
  return ack_names[code] or ("ack " .. code)
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
  local crc_present = v["flags.crc_present"] == 1
  local partial = v["flags.partial"] == 1
  local packet = tvb:len() > length and tvb(length):tvb() or nil
  local kind = v.record_type
  local text
  if kind == 3 then
    text = "bus reset, generation " .. v.generation
  elseif packet == nil then
    text = (record_type_names[kind] or "record") .. " without data"
  elseif kind == 0 then
    text = add_async(packet, root, crc_present, partial)
  elseif kind == 1 then
    text = add_ack(packet, root)
  elseif kind == 2 then
    text = add_phy(packet, root, crc_present)
  else
    text = "record type " .. kind
  end
  if kind == 0 and v["flags.ack_present"] == 1 then
    text = text .. "  " .. (ack_names[v.ack] or ("ack " .. v.ack))
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
  local text
  if request then
    add_flat(root:add(eth1394, tvb(0, CONTROL_WORD_SIZE), "control word"), tvb, 0, CONTROL_WORD, E)
    local packet_tree = tree:add(fw1394, tvb(CONTROL_WORD_SIZE), "IEEE 1394 request")
    text = add_async(tvb(CONTROL_WORD_SIZE):tvb(), packet_tree, true, false)
  elseif response then
    local packet_tree = tree:add(fw1394, tvb(0, length - EXTRA_SIZE), "IEEE 1394 response")
    text = add_async(tvb(0, length - EXTRA_SIZE):tvb(), packet_tree, true, false)
    local extra = root:add(eth1394, tvb(length - EXTRA_SIZE, EXTRA_SIZE), "extra bytes")
    add_flat(extra, tvb, length - EXTRA_SIZE, EXTRA_BYTES, E)
  else
    text = "not an Eth1394 datagram"
  end
  pinfo.cols.info = text
  return length
end

local encaps = wtap_encaps or wtap
DissectorTable.get("wtap_encap"):add(encaps["USER" .. (LINKTYPE - 147)], fw1394)
DissectorTable.get("udp.port"):add(UDP_PORT, eth1394)
"""
