// Parsers for the cloud formats the server sends (PCD ascii/binary/binary_compressed as PCL
// writes them, PLY ascii/binary_little_endian). They return only x, y, z as a Float32Array,
// which is all the 3D view needs; anything malformed throws an Error naming what is wrong.

const TYPE_READERS = {
  F4: (dv, o) => dv.getFloat32(o, true), F8: (dv, o) => dv.getFloat64(o, true),
  I1: (dv, o) => dv.getInt8(o), U1: (dv, o) => dv.getUint8(o),
  I2: (dv, o) => dv.getInt16(o, true), U2: (dv, o) => dv.getUint16(o, true),
  I4: (dv, o) => dv.getInt32(o, true), U4: (dv, o) => dv.getUint32(o, true),
};

function headerEnd(bytes, marker) {
  // Header is ASCII; find the line that starts with `marker` and return the offset after it.
  const text = new TextDecoder('latin1').decode(bytes.subarray(0, Math.min(bytes.length, 8192)));
  const re = new RegExp(`(^|\\n)${marker}[^\\n]*\\n`);
  const m = re.exec(text);
  if (!m) throw new Error(`cloud: no '${marker}' line in the first 8 KiB of the header`);
  return { text: text.slice(0, m.index + m[0].length), end: m.index + m[0].length };
}

export function parseCloud(buffer) {
  const bytes = new Uint8Array(buffer);
  const magic = new TextDecoder('latin1').decode(bytes.subarray(0, 3));
  if (magic === 'ply') return parsePly(bytes);
  return parsePcd(bytes);
}

export function parsePcd(bytes) {
  const { text, end } = headerEnd(bytes, 'DATA');
  const h = {};
  for (const line of text.split('\n')) {
    const parts = line.trim().split(/\s+/);
    if (parts[0] && !parts[0].startsWith('#')) h[parts[0]] = parts.slice(1);
  }
  const fields = h.FIELDS, sizes = (h.SIZE || []).map(Number), types = h.TYPE || [];
  const counts = (h.COUNT || fields.map(() => '1')).map(Number);
  const n = Number(h.POINTS?.[0] ?? (Number(h.WIDTH) * Number(h.HEIGHT)));
  if (!fields || sizes.length !== fields.length || types.length !== fields.length || !(n >= 0)) {
    throw new Error('PCD: FIELDS/SIZE/TYPE/POINTS header lines missing or inconsistent');
  }
  const ix = ['x', 'y', 'z'].map((f) => fields.indexOf(f));
  if (ix.some((i) => i < 0)) throw new Error(`PCD: fields ${fields.join(' ')} lack x, y or z`);
  const out = new Float32Array(n * 3);
  const mode = h.DATA[0];
  if (mode === 'ascii') {
    const col = []; let c = 0;
    fields.forEach((_, i) => { col.push(c); c += counts[i]; });
    const lines = new TextDecoder('latin1').decode(bytes.subarray(end)).split('\n');
    let k = 0;
    for (const line of lines) {
      if (k >= n) break;
      const v = line.trim().split(/\s+/);
      if (v.length < c) continue;
      for (let a = 0; a < 3; a++) out[k * 3 + a] = Number(v[col[ix[a]]]);
      k++;
    }
    if (k !== n) throw new Error(`PCD ascii: expected ${n} points, read ${k}`);
    return out;
  }
  const offsets = []; let stride = 0;
  fields.forEach((_, i) => { offsets.push(stride); stride += sizes[i] * counts[i]; });
  const readers = ix.map((i) => TYPE_READERS[types[i] + sizes[i]]);
  if (readers.some((r) => !r)) throw new Error('PCD: unsupported x/y/z type');
  if (mode === 'binary') {
    if (end + n * stride > bytes.length) throw new Error(`PCD binary: truncated (${n} points of ${stride} bytes)`);
    const dv = new DataView(bytes.buffer, bytes.byteOffset + end);
    for (let k = 0; k < n; k++) {
      for (let a = 0; a < 3; a++) out[k * 3 + a] = readers[a](dv, k * stride + offsets[ix[a]]);
    }
    return out;
  }
  if (mode === 'binary_compressed') {
    const dv0 = new DataView(bytes.buffer, bytes.byteOffset + end);
    const csize = dv0.getUint32(0, true), usize = dv0.getUint32(4, true);
    const raw = lzfDecompress(bytes.subarray(end + 8, end + 8 + csize), usize);
    const dv = new DataView(raw.buffer);
    // Compressed PCD stores each field as a column: all x, then all y, ...
    const colStart = []; let s = 0;
    fields.forEach((_, i) => { colStart.push(s); s += sizes[i] * counts[i] * n; });
    for (let k = 0; k < n; k++) {
      for (let a = 0; a < 3; a++) {
        const f = ix[a];
        out[k * 3 + a] = readers[a](dv, colStart[f] + k * sizes[f] * counts[f]);
      }
    }
    return out;
  }
  throw new Error(`PCD: unknown DATA mode '${mode}'`);
}

function lzfDecompress(src, outLen) {
  const dst = new Uint8Array(outLen);
  let i = 0, o = 0;
  while (i < src.length) {
    let ctrl = src[i++];
    if (ctrl < 32) {
      ctrl++;
      if (o + ctrl > outLen) throw new Error('PCD: LZF literal overruns output');
      while (ctrl--) dst[o++] = src[i++];
    } else {
      let len = ctrl >> 5;
      let ref = o - ((ctrl & 0x1f) << 8) - 1;
      if (len === 7) len += src[i++];
      ref -= src[i++];
      len += 2;
      if (ref < 0 || o + len > outLen) throw new Error('PCD: LZF back-reference out of range');
      while (len--) dst[o++] = dst[ref++];
    }
  }
  if (o !== outLen) throw new Error(`PCD: LZF produced ${o} bytes, header says ${outLen}`);
  return dst;
}

const PLY_TYPES = {
  char: 'I1', int8: 'I1', uchar: 'U1', uint8: 'U1', short: 'I2', int16: 'I2', ushort: 'U2',
  uint16: 'U2', int: 'I4', int32: 'I4', uint: 'U4', uint32: 'U4', float: 'F4', float32: 'F4',
  double: 'F8', float64: 'F8',
};

export function parsePly(bytes) {
  const { text, end } = headerEnd(bytes, 'end_header');
  const lines = text.split('\n').map((l) => l.trim());
  const format = lines.find((l) => l.startsWith('format'))?.split(/\s+/)[1];
  // Only the vertex element matters; it must come first for the byte offsets below.
  let n = -1; const props = []; let inVertex = false;
  for (const l of lines) {
    const p = l.split(/\s+/);
    if (p[0] === 'element') {
      if (n >= 0 && !inVertex) break;
      inVertex = p[1] === 'vertex';
      if (inVertex) n = Number(p[2]);
      else if (n < 0) throw new Error('PLY: vertex must be the first element');
    } else if (p[0] === 'property' && inVertex) {
      if (p[1] === 'list') throw new Error('PLY: list property inside vertex');
      props.push({ name: p[2], type: PLY_TYPES[p[1]] });
    }
  }
  const ix = ['x', 'y', 'z'].map((f) => props.findIndex((p) => p.name === f));
  if (n < 0 || ix.some((i) => i < 0)) throw new Error('PLY: no vertex element with x, y, z');
  const out = new Float32Array(n * 3);
  if (format === 'ascii') {
    const rows = new TextDecoder('latin1').decode(bytes.subarray(end)).split('\n');
    for (let k = 0; k < n; k++) {
      const v = (rows[k] || '').trim().split(/\s+/);
      if (v.length < props.length) throw new Error(`PLY ascii: vertex ${k} has ${v.length} values`);
      for (let a = 0; a < 3; a++) out[k * 3 + a] = Number(v[ix[a]]);
    }
    return out;
  }
  if (format !== 'binary_little_endian') throw new Error(`PLY: unsupported format '${format}'`);
  const offsets = []; let stride = 0;
  for (const p of props) {
    if (!p.type) throw new Error('PLY: unknown property type');
    offsets.push(stride); stride += Number(p.type.slice(1));
  }
  if (end + n * stride > bytes.length) throw new Error('PLY binary: truncated');
  const dv = new DataView(bytes.buffer, bytes.byteOffset + end);
  const readers = ix.map((i) => TYPE_READERS[props[i].type]);
  for (let k = 0; k < n; k++) {
    for (let a = 0; a < 3; a++) out[k * 3 + a] = readers[a](dv, k * stride + offsets[ix[a]]);
  }
  return out;
}
