// The page's pure modules under node: error messages from API bodies, file names from
// Content-Disposition, the grasp geometry the canvas draws, the strategy fields' inputs, the
// fractal request body, the stiffness view's choices from /v1/info, the objects panel's choices
// and label decoding, the mesh
// panel's query, scale and table rows, and the robot panel's command body, states, result numbers
// and error messages.
import assert from 'node:assert/strict';
import { describe, it } from 'node:test';
import { deflateSync } from 'node:zlib';

import { ApiError, describeError, fileNameFromDisposition, parseErrorBody } from '../../web/src/api.js';
import { fractalBody } from '../../web/src/fractals.js';
import { angleDegrees, graspShape, isDrawable } from '../../web/src/grasp_geometry.js';
import {
  graspInPose, graspQuality, graspRows, lengthText, meshFileFormat, meshQuery, meshScale,
  meshSummary, poseRows, qualityScale, usableCounts,
} from '../../web/src/mesh_grasps_model.js';
import {
  commandUrl, describeRobotError, isFinalState, isValidCommandId, newCommandId, resultSummary,
  robotCommandBody, stateSteps,
} from '../../web/src/robot_model.js';
import {
  decodeLabelsPng, instanceAt, optionalText, segmentationChoices,
} from '../../web/src/segmentation_model.js';
import {
  meanStiffnessText, stiffnessForm, stiffnessModel, strategyChoices,
} from '../../web/src/stiffness.js';
import { fieldLabel, strategyFieldInputs } from '../../web/src/strategy_fields_model.js';

describe('API errors', () => {
  it('shows the message and field of the error body', () => {
    const e = parseErrorBody(415, 'Unsupported Media Type',
      '{"error": {"code": "unsupported_media_type", "message": "PNG depth must be 16-bit", "field": "depth"}}');
    assert.ok(e instanceof ApiError);
    assert.equal(e.status, 415);
    assert.equal(e.code, 'unsupported_media_type');
    assert.equal(describeError(e), 'PNG depth must be 16-bit (field: depth)');
    assert.equal(describeError(parseErrorBody(404, 'Not Found', '{"error": {"code": "not_found", "message": "no resource at /x"}}')),
      'no resource at /x');
  });

  it('falls back to the status line for bodies that are not the API\'s', () => {
    assert.equal(describeError(parseErrorBody(502, 'Bad Gateway', '<html>proxy</html>')),
      'The service answered 502 Bad Gateway.');
    assert.equal(describeError(parseErrorBody(500, '', '{"error": 3}')), 'The service answered 500.');
    assert.match(describeError(new TypeError('Failed to fetch')), /^Could not reach the service: Failed to fetch/);
  });

  it('takes plain file names from Content-Disposition', () => {
    assert.equal(fileNameFromDisposition('attachment; filename="fractal-seed42-alpha0.3.obj"', 'x'),
      'fractal-seed42-alpha0.3.obj');
    assert.equal(fileNameFromDisposition('attachment; filename=mesh.stl', 'x'), 'mesh.stl');
    assert.equal(fileNameFromDisposition('attachment; filename="../../etc/passwd"', 'x'), 'passwd');
    assert.equal(fileNameFromDisposition(null, 'fallback.obj'), 'fallback.obj');
    assert.equal(fileNameFromDisposition('inline', 'fallback.obj'), 'fallback.obj');
  });
});

describe('grasp geometry', () => {
  const grasp = {
    center_px: { u: 100, v: 50 }, angle_rad: 0, opening_px: 40, finger_width_px: 10,
    finger_thickness_px: 6,
  };

  it('puts the fingers outside the opening along the closing axis', () => {
    const shape = graspShape(grasp);
    // Closing axis along +u: finger centres at u = 100 -/+ (20 + 3).
    assert.deepEqual(shape.line, [[77, 50], [123, 50]]);
    const xs = shape.fingers[0].map((p) => p[0]);
    const ys = shape.fingers[0].map((p) => p[1]);
    assert.deepEqual([Math.min(...xs), Math.max(...xs)], [74, 80]); // thickness 6 along u
    assert.deepEqual([Math.min(...ys), Math.max(...ys)], [45, 55]); // width 10 across
  });

  it('turns with angle_rad from +u towards +v (image down)', () => {
    const shape = graspShape({ ...grasp, angle_rad: Math.PI / 2 });
    const [a, b] = shape.line;
    assert.ok(Math.abs(a[0] - 100) < 1e-9 && Math.abs(a[1] - 27) < 1e-9);
    assert.ok(Math.abs(b[0] - 100) < 1e-9 && Math.abs(b[1] - 73) < 1e-9);
    assert.equal(angleDegrees(Math.PI / 2), 90);
    assert.equal(angleDegrees(-Math.PI / 4), 135);
  });

  it('refuses to draw what is not finite', () => {
    assert.ok(isDrawable(grasp));
    assert.ok(!isDrawable({ ...grasp, angle_rad: NaN }));
    assert.ok(!isDrawable({ ...grasp, opening_px: 1e9 }));
    assert.ok(!isDrawable({ ...grasp, center_px: undefined }));
  });
});

describe('fractal request body', () => {
  it('sends the maps as N or [min, max] and leaves empty fields to the service', () => {
    assert.deepEqual(fractalBody({ seed: 42, mapsMin: 2, mapsMax: 7, points: 10000, sigma: 0.05,
      alpha: 0.3, openingMm: 50, format: 'obj' }),
    { seed: 42, maps: [2, 7], points: 10000, sigma: 0.05, alpha: 0.3, scale: { opening_mm: 50 }, format: 'obj' });
    assert.deepEqual(fractalBody({ mapsMin: 3, mapsMax: 3, format: 'stl_binary' }), { maps: 3, format: 'stl_binary' });
    assert.deepEqual(fractalBody({ mapsMax: 4, format: 'json' }), { maps: 4, format: 'json' });
  });
});

describe('stiffness view', () => {
  const model = { name: 'pix2stiffness', kind: 'stiffness', input_size: 256, parameters: 1335073 };

  it('finds the stiffness model in info.models, or none', () => {
    assert.deepEqual(stiffnessModel({ models: [model] }), model);
    assert.deepEqual(stiffnessModel({ models: [{ name: 'x', kind: 'other' }, model] }), model);
    assert.equal(stiffnessModel({ models: [] }), null);
    assert.equal(stiffnessModel({ models: [{ name: 'x', kind: 'other' }] }), null);
    assert.equal(stiffnessModel({}), null); // a service from before the models list
    assert.equal(stiffnessModel(null), null); // no info at all
  });

  it('offers info.strategies with the default preselected', () => {
    const withModel = strategyChoices({ strategies: ['fge', 'stiffness'], default_strategy: 'stiffness' });
    assert.deepEqual(withModel.options.map((o) => o.value), ['fge', 'stiffness']);
    assert.equal(withModel.selected, 'stiffness');
    assert.equal(withModel.options[0].label, 'FGE (fast graspability evaluation)');
    assert.match(withModel.options[1].label, /^Stiffness/);
    const both = strategyChoices({ strategies: ['fge', 'stiffness', 'deformability'],
      default_strategy: 'deformability' });
    assert.equal(both.selected, 'deformability');
    assert.match(both.options[2].label, /^Deformability-aware/);
    assert.deepEqual(strategyChoices({ strategies: ['fge'], default_strategy: 'fge' }),
      { options: [{ value: 'fge', label: 'FGE (fast graspability evaluation)' }], selected: 'fge' });
    // A default that is not offered, an unknown name, no list, no info.
    assert.equal(strategyChoices({ strategies: ['fge'], default_strategy: 'stiffness' }).selected, 'fge');
    assert.deepEqual(strategyChoices({ strategies: ['new'] }).options, [{ value: 'new', label: 'new' }]);
    assert.equal(strategyChoices({ strategies: ['fge', 'gqcnn'] }).options[1].label,
      'GQ-CNN (Dex-Net 2.0 policy)');
    assert.deepEqual(strategyChoices({}).options.map((o) => o.value), ['fge']);
    assert.equal(strategyChoices(null).selected, 'fge');
  });

  it('writes mean stiffness with 2 decimals, an en dash without a model', () => {
    assert.equal(meanStiffnessText(0.98765), '0.99');
    assert.equal(meanStiffnessText(0), '0.00');
    assert.equal(meanStiffnessText(1), '1.00');
    assert.equal(meanStiffnessText(null), '–');
    assert.equal(meanStiffnessText(undefined), '–');
    assert.equal(meanStiffnessText(Number.NaN), '–');
  });

  it('asks /v1/stiffness for the same depth and camera, without the grasp settings', async () => {
    const grasps = new FormData();
    grasps.append('depth', new Blob([new Uint8Array([1, 2, 3])]), 'frame.npy');
    grasps.append('intrinsics', new Blob(['{"fx": 525}']), 'cam.intr');
    grasps.append('fx', '525');
    grasps.append('top_k', '5');
    grasps.append('strategy', 'stiffness');
    const form = stiffnessForm(grasps);
    assert.deepEqual([...form.keys()], ['depth', 'intrinsics', 'fx', 'format']);
    assert.equal(form.get('format'), 'color');
    assert.equal(form.get('depth').name, 'frame.npy');
    assert.deepEqual([...new Uint8Array(await form.get('depth').arrayBuffer())], [1, 2, 3]);
    assert.equal(form.get('intrinsics').name, 'cam.intr');
    assert.equal(stiffnessForm(grasps, 'npy').get('format'), 'npy');
  });
});

describe('robot panel model', () => {
  const grasp = {
    rank: 1, score: 0.125, opening_m: 0.05, center_px: { u: 1, v: 2 },
    pose: { frame: 'camera', position_m: [-0.1478, -0.0398, 0.5258], orientation_wxyz: [0.773, 0, 0, 0.634] },
  };

  it('makes fresh ids the service accepts', () => {
    const a = newCommandId();
    const b = newCommandId();
    assert.match(a, /^web-[0-9a-f]{32}$/);
    assert.notEqual(a, b);
    assert.ok(isValidCommandId(a));
    // Deterministic with a given source of bytes: each byte as two hex digits.
    assert.equal(newCommandId((bytes) => bytes.fill(0xab)), `web-${'ab'.repeat(16)}`);
    assert.ok(!isValidCommandId('has space'));
    assert.ok(!isValidCommandId('x'.repeat(65)));
    assert.ok(!isValidCommandId(''));
  });

  it('sends the grasp as /v1/grasps returned it, plus the id and the choices made', () => {
    assert.deepEqual(robotCommandBody(grasp, 'web-1'), { ...grasp, id: 'web-1' });
    assert.deepEqual(robotCommandBody(grasp, 'web-1', { robotId: 'arm-2', forceN: 4.5 }),
      { ...grasp, id: 'web-1', robot_id: 'arm-2', force_n: 4.5 });
    // Empty fields are left to the service's defaults.
    assert.deepEqual(robotCommandBody(grasp, 'web-1', { robotId: '', forceN: undefined }), { ...grasp, id: 'web-1' });
    assert.throws(() => robotCommandBody(null, 'web-1'), /no grasp selected/);
    assert.throws(() => robotCommandBody(grasp, 'bad id'), /bad command id/);
  });

  it('follows the Location, else the route of the id', () => {
    assert.equal(commandUrl('/v1/robot/grasps/web-1', 'web-1'), '/v1/robot/grasps/web-1');
    assert.equal(commandUrl(null, 'web-1'), '/v1/robot/grasps/web-1');
    // Only the service's own route: a Location elsewhere is not followed with the token.
    assert.equal(commandUrl('https://elsewhere.example/x', 'web-1'), '/v1/robot/grasps/web-1');
  });

  it('knows the final states and shows the path a command took', () => {
    for (const s of ['succeeded', 'failed', 'rejected', 'timed_out']) assert.ok(isFinalState(s), s);
    for (const s of ['queued', 'sent', 'executing', 'result', undefined]) assert.ok(!isFinalState(s), s);
    assert.deepEqual(stateSteps([]), ['sent', 'executing', 'result']);
    assert.deepEqual(stateSteps(['sent', 'failed']), ['sent', 'executing', 'failed']);
    assert.deepEqual(stateSteps(['queued', 'sent', 'executing', 'succeeded']),
      ['queued', 'sent', 'executing', 'succeeded']);
  });

  it('turns the result into millimetres, percent and damage above 20 %', () => {
    const crushed = resultSummary({
      outcome: 'failed', reason: 'crushed: held object 3', robot_id: 'sim', contact_width_m: 0.03567,
      grasped_width_m: 0.027, deformation_rate: (0.03567 - 0.027) / 0.03567, execution_s: 0.221,
      round_trip_s: 0.227, late: false,
    });
    assert.equal(crushed.contactWidthMm.toFixed(2), '35.67');
    assert.equal(crushed.graspedWidthMm.toFixed(2), '27.00');
    assert.equal(crushed.deformationPercent.toFixed(1), '24.3');
    assert.equal(crushed.damaged, true);
    const held = resultSummary({ outcome: 'succeeded', contact_width_m: 0.04341, grasped_width_m: 0.04323,
      deformation_rate: 0.2 });
    assert.equal(held.damaged, false); // exactly 20 % is not above it
    // Nothing touched: zeros from the robot mean no widths and no deformation, not 0 mm.
    const empty = resultSummary({ outcome: 'failed', reason: 'empty: ...', contact_width_m: 0,
      grasped_width_m: 0, deformation_rate: 0 });
    assert.deepEqual([empty.contactWidthMm, empty.graspedWidthMm, empty.deformationPercent, empty.damaged],
      [null, null, null, null]);
    assert.equal(resultSummary(undefined), null);
    assert.equal(resultSummary({ outcome: 'succeeded', late: true }).late, true);
  });

  it('says what 401, 403, 409, 422 and 503 mean, with the API\'s own message', () => {
    const body = (code, message, field) => JSON.stringify({ error: { code, message, field } });
    assert.equal(describeRobotError(parseErrorBody(401, '', body('unauthorized', "this route needs 'Authorization: Bearer <token>' (a robot token)", 'Authorization'))),
      "The robot routes need a token: this route needs 'Authorization: Bearer <token>' (a robot token) (field: Authorization)");
    assert.equal(describeRobotError(parseErrorBody(403, '', body('forbidden', 'the token is not accepted', 'Authorization'))),
      'Token refused: the token is not accepted (field: Authorization)');
    assert.equal(describeRobotError(parseErrorBody(409, '', body('conflict', 'id web-1 was used for another grasp', 'id'))),
      'This command id was already used for another grasp: id web-1 was used for another grasp (field: id)');
    assert.equal(describeRobotError(parseErrorBody(422, '', body('unprocessable', 'outside the workspace', 'pose.position_m[2]'))),
      'The service will not send this grasp: outside the workspace (field: pose.position_m[2])');
    const busy = parseErrorBody(503, '', body('unavailable', 'no robot is alive'));
    busy.retryAfterS = 2;
    assert.equal(describeRobotError(busy), 'No robot can take it now: no robot is alive (try again in 2 s)');
    assert.equal(describeRobotError(parseErrorBody(500, '', body('internal', 'journal full'))), 'journal full');
    assert.match(describeRobotError(new TypeError('Failed to fetch')), /^Could not reach the service/);
  });
});

// ---- the objects panel (src/segmentation_model.js) ----

function crc32(bytes) {
  let c = ~0;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k += 1) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
  }
  return ~c >>> 0;
}

function chunk(type, data) {
  const out = Buffer.alloc(12 + data.length);
  out.writeUInt32BE(data.length, 0);
  out.write(type, 4, 'latin1');
  Buffer.from(data).copy(out, 8);
  out.writeUInt32BE(crc32(out.subarray(4, 8 + data.length)), 8 + data.length);
  return out;
}

function paethPredictor(a, b, c) {
  const p = a + b - c;
  const [pa, pb, pc] = [Math.abs(p - a), Math.abs(p - b), Math.abs(p - c)];
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

/** A 16-bit grey PNG of `ids` (rows of numbers), row y filtered with filter type y % 5. */
function labelsPng(ids) {
  const height = ids.length;
  const width = ids[0].length;
  const stride = 2 * width;
  const raw = [];
  let previous = new Array(stride).fill(0);
  ids.forEach((row, y) => {
    const line = row.flatMap((id) => [id >> 8, id & 0xff]);
    const filter = y % 5;
    raw.push(filter);
    for (let i = 0; i < stride; i += 1) {
      const left = i >= 2 ? line[i - 2] : 0;
      const up = previous[i];
      const upLeft = i >= 2 ? previous[i - 2] : 0;
      const predict = [0, left, up, (left + up) >> 1, paethPredictor(left, up, upLeft)][filter];
      raw.push((line[i] - predict) & 0xff);
    }
    previous = line;
  });
  const header = Buffer.alloc(13);
  header.writeUInt32BE(width, 0);
  header.writeUInt32BE(height, 4);
  header.set([16, 0, 0, 0, 0], 8);
  return Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', header),
    chunk('IDAT', deflateSync(Buffer.from(raw))), chunk('IEND', Buffer.alloc(0))]);
}

describe('objects panel', () => {
  it('offers the methods /v1/info lists and preselects its default', () => {
    assert.deepEqual(segmentationChoices({ segmentation_methods: ['model', 'pcl'],
      default_segmentation_method: 'model' }).selected, 'model');
    const all = segmentationChoices({ segmentation_methods: ['model', 'pcl', 'fused', 'magic'],
      default_segmentation_method: 'model' });
    assert.deepEqual(all.options.map((o) => o.value), ['model', 'pcl', 'fused']);
    assert.equal(all.options[2].label, 'Model + PCL (other cameras)');
    const plain = segmentationChoices({ segmentation_methods: ['pcl'], default_segmentation_method: 'pcl' });
    assert.deepEqual(plain.options.map((o) => o.value), ['pcl']);
    assert.equal(plain.selected, 'pcl');
    assert.deepEqual(segmentationChoices(null).options.map((o) => o.value), ['pcl']);
  });

  it('writes optional values with two decimals or a dash', () => {
    assert.equal(optionalText(0.4567), '0.46');
    assert.equal(optionalText(null), '–');
    assert.equal(optionalText(undefined), '–');
  });

  it('decodes 16-bit label PNGs with every row filter, ids above 255 included', async () => {
    const ids = [
      [0, 1, 1, 2, 300],
      [0, 1, 2, 2, 300],
      [7, 7, 0, 0, 65535],
      [7, 7, 0, 513, 513],
      [0, 0, 0, 513, 0],
      [9, 8, 7, 6, 5],
    ];
    const labels = await decodeLabelsPng(labelsPng(ids));
    assert.equal(labels.width, 5);
    assert.equal(labels.height, 6);
    assert.deepEqual([...labels.ids], ids.flat());
    assert.equal(instanceAt(labels, 4.7, 2.2), 65535);
    assert.equal(instanceAt(labels, 1.5, 0.5), 1);
    assert.equal(instanceAt(labels, -1, 0), 0);
    assert.equal(instanceAt(labels, 5, 0), 0);
  });

  it('refuses PNGs that are not 16-bit grey', async () => {
    const png = labelsPng([[1, 2]]);
    png[24] = 8; // bit depth in IHDR
    await assert.rejects(decodeLabelsPng(png), /16-bit grey/);
    await assert.rejects(decodeLabelsPng(Buffer.from('not a png')), /not a PNG/);
  });
});

describe('mesh panel model', () => {
  const pose = (index, extra = {}) => ({ pose: index, aligned: true, collision_free: true,
    approach_table_angle_deg: 0, approach_offset_deg: 0, approach_o: [0, 0, -1], ...extra });
  const result = {
    center_of_mass_m: [0, 0, 0],
    stable_poses: [
      { index: 0, probability: 0.5, com_height_m: 0.01, table_from_object: {} },
      { index: 1, probability: 0.25, com_height_m: 0.0205, table_from_object: {} },
    ],
    grasps: [
      { rank: 0, width_m: 0.02, ferrari_canny: 0.004, robust_ferrari_canny: 0.003,
        poses: [pose(0), pose(1, { aligned: false, approach_table_angle_deg: 33.34 })] },
      { rank: 1, width_m: 0.0315, ferrari_canny: 0.002, robust_ferrari_canny: null,
        poses: [pose(0, { collision_free: false, approach_offset_deg: null }), pose(1)] },
      { rank: 2, width_m: 0.01, ferrari_canny: 0.001, robust_ferrari_canny: 0.001, poses: [] },
    ],
    timing_ms: { total: 12.4 },
    mesh: { format: 'obj', vertices: 8, triangles: 12, unit_scale_m: 0.001, rescale_factor: 2,
      scale_applied: 0.002, extents_m: [0.02, 0.02, 0.0205],
      repairs: ['welded 28 duplicate vertices (equal coordinates)'], warnings: [], future_field: 1 },
  };

  it('sends format=json, the unit and only the filled-in options', () => {
    assert.equal(meshQuery({ unit: 'm' }), 'format=json&unit=m');
    assert.equal(meshQuery({ unit: 'mm', num_grasps: 50, robust_samples: 0, seed: 7,
      friction_coefficient: 0.4, rescale: true }),
    'format=json&unit=mm&num_grasps=50&robust_samples=0&seed=7&friction_coefficient=0.4'
      + '&rescale_min_extent_mm=40');
  });

  it('reads the file with the service\'s format name, else by its extension', () => {
    assert.equal(meshFileFormat('part.bin', 'ply_binary'), 'ply');
    assert.equal(meshFileFormat('part.STL', undefined), 'stl');
    assert.equal(meshFileFormat('cube.obj', null), 'obj');
    assert.equal(meshFileFormat('notes.txt', 'unknown'), null);
  });

  it('scales the file by scale_applied, else by its unit', () => {
    assert.equal(meshScale(result.mesh, 'mm'), 0.002);
    assert.equal(meshScale({ scale: 0.5 }, 'm'), 0.5);
    assert.equal(meshScale({}, 'mm'), 0.001);
    assert.equal(meshScale(undefined, 'm'), 1);
    assert.equal(meshScale({ scale_applied: 0 }, 'm'), 1);
  });

  it('finds a grasp in a pose and its quality (robust, else nominal)', () => {
    assert.equal(graspInPose(result.grasps[0], 1).approach_table_angle_deg, 33.34);
    assert.equal(graspInPose(result.grasps[2], 0), null);
    assert.equal(graspQuality(result.grasps[0]), 0.003);
    assert.equal(graspQuality(result.grasps[1]), 0.002);
    const scale = qualityScale(result.grasps);
    assert.deepEqual(result.grasps.map(scale), [1, 0.5, 0]);
    assert.equal(qualityScale([result.grasps[0]])(result.grasps[0]), 1);
  });

  it('writes the pose and grasp table rows from the answer', () => {
    assert.deepEqual(usableCounts(result), [1, 1]);
    assert.deepEqual(poseRows(result), [['0', '50.0', '10.0', '1'], ['1', '25.0', '20.5', '1']]);
    assert.deepEqual(graspRows(result, 1), [
      ['0', '20.0', '0.0030', '0.0040', 'no', 'yes', '33.3'],
      ['1', '31.5', '–', '0.0020', 'yes', 'yes', '0.0'],
      ['2', '10.0', '0.0010', '0.0010', '–', '–', '–'],
    ]);
    assert.equal(graspRows(result, 0)[1][5], 'no');
  });

  it('sums up the upload, repairs included, and ignores fields it does not know', () => {
    assert.equal(meshSummary(result, 'cube.obj'),
      'cube.obj, obj, 12 triangles, 8 vertices, unit mm, rescaled × 2, extents 20.0 × 20.0 × 20.5 mm:'
      + ' 2 stable poses, 3 grasps, 12 ms. Repairs: welded 28 duplicate vertices (equal coordinates).');
    assert.equal(meshSummary({ ...result, mesh: { unit_scale_m: 1, rescale_factor: 1,
      warnings: ['2 faces cut through each other'] } }, 'a.ply'),
    'a.ply, unit m: 2 stable poses, 3 grasps, 12 ms. Warnings: 2 faces cut through each other.');
    assert.equal(meshSummary({ ...result, grasps: [], mesh: {}, no_grasp: {
      reason: 'wider_than_stroke', needed_stroke_m: 0.072,
      message: 'the object is 72.0 mm at its narrowest, wider than the 50.0 mm stroke in every '
        + 'direction: it needs a stroke of at least 72.0 mm' } }, 'box.obj'),
    'box.obj: 2 stable poses, 0 grasps, 12 ms. No usable grasp: the object is 72.0 mm at its '
      + 'narrowest, wider than the 50.0 mm stroke in every direction: it needs a stroke of at least '
      + '72.0 mm.');
    assert.equal(meshSummary({ ...result, mesh: undefined, timing_ms: undefined }, 'a.stl'),
      'a.stl: 2 stable poses, 3 grasps, – ms.');
  });

  it('writes lengths with a fitting unit', () => {
    assert.equal(lengthText(0.01), '1 cm');
    assert.equal(lengthText(0.1), '10 cm');
    assert.equal(lengthText(1), '1 m');
    assert.equal(lengthText(0.001), '1 mm');
    assert.equal(lengthText(0), '');
  });
});

describe('strategy fields', () => {
  const info = {
    strategy_fields: [
      { name: 'fge', fields: [] },
      {
        name: 'deformability',
        fields: [
          { name: 'target_policy', kind: 'choice', unit: '', default: 'highest', doc: 'which',
            choices: ['highest', 'least_deformable'] },
          { name: 'slice_step_mm', kind: 'number', unit: 'mm', default: 10, doc: 'L',
            minimum: 1, maximum: 200 },
          { name: 'num_slices', kind: 'integer', unit: '', default: 5, doc: 'M', minimum: 1,
            maximum: 20 },
          { name: 'opening_fractions', kind: 'number_list', unit: '', default: [0.5, 0.75, 1],
            doc: 'openings', minimum: 0, maximum: 1, max_count: 8 },
          { name: 'future', kind: 'tensor', default: 0 },
          { kind: 'number' },
        ],
      },
    ],
  };
  it('builds one input per field of the selected strategy, in the table\'s order', () => {
    const inputs = strategyFieldInputs(info, 'deformability');
    assert.deepEqual(inputs.map((i) => [i.name, i.input]), [['target_policy', 'select'],
      ['slice_step_mm', 'number'], ['num_slices', 'number'], ['opening_fractions', 'text']]);
    assert.deepEqual(inputs[0].options, ['highest', 'least_deformable']);
    assert.equal(inputs[0].defaultText, 'highest');
    assert.deepEqual([inputs[1].min, inputs[1].max, inputs[1].step], [1, 200, 'any']);
    assert.equal(inputs[2].step, '1');
    assert.equal(inputs[3].defaultText, '0.5,0.75,1');
  });
  it('gives none for a strategy without fields, an unknown one, or no info', () => {
    assert.deepEqual(strategyFieldInputs(info, 'fge'), []);
    assert.deepEqual(strategyFieldInputs(info, 'nope'), []);
    assert.deepEqual(strategyFieldInputs(undefined, 'deformability'), []);
    assert.deepEqual(strategyFieldInputs({ strategy_fields: 'x' }, 'deformability'), []);
  });
  it('labels a field by its name and unit', () => {
    assert.equal(fieldLabel({ name: 'max_press_depth_mm', unit: 'mm' }), 'Max press depth (mm)');
    assert.equal(fieldLabel({ name: 'min_target_area_px', unit: 'px' }), 'Min target area (px)');
    assert.equal(fieldLabel({ name: 'cem_samples', unit: '' }), 'Cem samples');
  });
});
