// Reader for OctoMap's binary tree format (.bt, OcTree::writeBinary): a text header ending in
// "data\n", then per inner node two bytes holding 2 bits per child — 00 unknown, 01 occupied
// leaf, 10 free leaf, 11 inner node (recursed depth-first in child order). Child i sits on the
// + side of x/y/z when bit 0/1/2 of i is set; the root (tree depth 16) is centred on 0.

const TREE_DEPTH = 16;

// Calls visit(cx, cy, cz, size, occupied) for every known leaf. Throws on malformed input.
export function forEachBtLeaf(buffer, visit) {
  const bytes = new Uint8Array(buffer);
  const head = new TextDecoder('latin1').decode(bytes.subarray(0, Math.min(bytes.length, 4096)));
  if (!head.startsWith('# Octomap OcTree binary file')) throw new Error('.bt: missing OctoMap binary header');
  const m = /(?:^|\n)data\n/.exec(head);
  const res = Number(/(?:^|\n)res ([^\n]+)\n/.exec(head)?.[1]);
  const id = /(?:^|\n)id ([^\n]+)\n/.exec(head)?.[1];
  if (!m || !(res > 0)) throw new Error('.bt: header lacks "res" or "data"');
  if (id !== 'OcTree') throw new Error(`.bt: tree type '${id}' is not OcTree`);
  let pos = m.index + m[0].length;
  if (pos >= bytes.length) return res;   // empty tree
  // Explicit stack instead of recursion: a corrupt file must not blow the JS stack.
  const stack = [[0, 0, 0, res * 2 ** TREE_DEPTH, 0]];
  while (stack.length) {
    const [cx, cy, cz, size, depth] = stack.pop();
    if (pos + 2 > bytes.length) throw new Error('.bt: truncated node data');
    if (depth >= TREE_DEPTH) throw new Error('.bt: tree deeper than 16 levels');
    const bits = bytes[pos] | (bytes[pos + 1] << 8);
    pos += 2;
    const half = size / 4, child = size / 2;
    const inner = [];
    for (let i = 0; i < 8; i++) {
      const code = (bits >> (2 * i)) & 3;   // bit 2i is the low bit of each pair
      if (code === 0) continue;
      const x = cx + (i & 1 ? half : -half), y = cy + (i & 2 ? half : -half), z = cz + (i & 4 ? half : -half);
      if (code === 3) inner.push([x, y, z, child, depth + 1]);
      else visit(x, y, z, child, code === 2);   // pair (0,1) read as 2 = occupied
    }
    // Depth-first in child order: push reversed so child 0 is read first.
    for (let k = inner.length - 1; k >= 0; k--) stack.push(inner[k]);
  }
  if (pos !== bytes.length) throw new Error(`.bt: ${bytes.length - pos} trailing bytes after the tree`);
  return res;
}

// Ground footprint of the observed space inside a tile: a cells x cells mask (1 = some free
// or occupied leaf covers this x/y cell at any height), row 0 at the tile's min y.
export function observedFootprint(buffer, tileMin, tileSize, cells = 128) {
  const mask = new Uint8Array(cells * cells);
  const cell = tileSize / cells;
  forEachBtLeaf(buffer, (x, y, _z, size) => {
    const i0 = Math.max(0, Math.floor((x - size / 2 - tileMin[0]) / cell));
    const i1 = Math.min(cells - 1, Math.ceil((x + size / 2 - tileMin[0]) / cell) - 1);
    const j0 = Math.max(0, Math.floor((y - size / 2 - tileMin[1]) / cell));
    const j1 = Math.min(cells - 1, Math.ceil((y + size / 2 - tileMin[1]) / cell) - 1);
    for (let j = j0; j <= j1; j++) for (let i = i0; i <= i1; i++) mask[j * cells + i] = 1;
  });
  return { mask, cells };
}
