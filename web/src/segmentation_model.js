// What the segmentation view needs without a DOM: the methods GET /v1/info offers, the label PNG
// of POST /v1/segmentation?format=labels decoded to instance ids (a browser's image decoders
// reduce 16-bit PNGs to 8 bits, which would lose the ids), and how the table writes values.
// Tested in tests/web/unit.test.mjs.

/** The segmentation methods to offer and the one to preselect (pcl only without info). */
export function segmentationChoices(info) {
  const listed = info && Array.isArray(info.segmentation_methods)
    ? info.segmentation_methods.filter((m) => m === 'model' || m === 'pcl' || m === 'fused') : [];
  const names = listed.length ? [...new Set(listed)] : ['pcl'];
  const wanted = info && info.default_segmentation_method;
  const labels = {
    model: 'Learned model',
    pcl: 'PCL baseline (clustering)',
    fused: 'Model + PCL (other cameras)',
  };
  return {
    options: names.map((value) => ({ value, label: labels[value] })),
    selected: names.includes(wanted) ? wanted : names[0],
  };
}

/** A deformability or stiffness for the table: 2 decimals, an en dash when null. */
export function optionalText(value) {
  return typeof value === 'number' && Number.isFinite(value) ? value.toFixed(2) : '–';
}

const PNG_SIGNATURE = [137, 80, 78, 71, 13, 10, 26, 10];

function paeth(a, b, c) {
  const p = a + b - c;
  const pa = Math.abs(p - a);
  const pb = Math.abs(p - b);
  const pc = Math.abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

async function inflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

/**
 * Decodes a 16-bit greyscale, non-interlaced PNG (what the service sends as labels) into
 * {width, height, ids: Uint16Array} (row-major; 0 = background). Throws on anything else.
 */
export async function decodeLabelsPng(buffer) {
  const bytes = new Uint8Array(buffer);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (!PNG_SIGNATURE.every((b, i) => bytes[i] === b)) throw new Error('labels: not a PNG');
  let offset = 8;
  let width = 0;
  let height = 0;
  const chunks = [];
  while (offset + 8 <= bytes.length) {
    const length = view.getUint32(offset);
    const type = String.fromCharCode(...bytes.subarray(offset + 4, offset + 8));
    const data = bytes.subarray(offset + 8, offset + 8 + length);
    if (type === 'IHDR') {
      width = view.getUint32(offset + 8);
      height = view.getUint32(offset + 12);
      const [depth, colour, , , interlace] = data.subarray(8, 13);
      if (depth !== 16 || colour !== 0 || interlace !== 0) {
        throw new Error('labels: expected a 16-bit grey, non-interlaced PNG');
      }
    } else if (type === 'IDAT') {
      chunks.push(data);
    } else if (type === 'IEND') {
      break;
    }
    offset += 12 + length;
  }
  const packed = new Uint8Array(chunks.reduce((n, c) => n + c.length, 0));
  let at = 0;
  for (const c of chunks) {
    packed.set(c, at);
    at += c.length;
  }
  const raw = await inflate(packed);
  const stride = width * 2;
  if (raw.length < height * (stride + 1)) throw new Error('labels: truncated PNG');
  const ids = new Uint16Array(width * height);
  let previous = new Uint8Array(stride);
  for (let y = 0; y < height; y += 1) {
    const filter = raw[y * (stride + 1)];
    const line = raw.slice(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let i = 0; i < stride; i += 1) {
      const left = i >= 2 ? line[i - 2] : 0;
      const up = previous[i];
      const upLeft = i >= 2 ? previous[i - 2] : 0;
      let add = 0;
      if (filter === 1) add = left;
      else if (filter === 2) add = up;
      else if (filter === 3) add = (left + up) >> 1;
      else if (filter === 4) add = paeth(left, up, upLeft);
      line[i] = (line[i] + add) & 0xff;
    }
    for (let x = 0; x < width; x += 1) ids[y * width + x] = (line[2 * x] << 8) | line[2 * x + 1];
    previous = line;
  }
  return { width, height, ids };
}

/** The instance id at image pixel (u, v) of decoded labels; 0 outside or on background. */
export function instanceAt(labels, u, v) {
  const x = Math.floor(u);
  const y = Math.floor(v);
  if (!labels || x < 0 || y < 0 || x >= labels.width || y >= labels.height) return 0;
  return labels.ids[y * labels.width + x];
}
