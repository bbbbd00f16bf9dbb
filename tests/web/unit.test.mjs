// The page's pure modules under node: error messages from API bodies, file names from
// Content-Disposition, the grasp geometry the canvas draws, the fractal request body.
import assert from 'node:assert/strict';
import { describe, it } from 'node:test';

import { ApiError, describeError, fileNameFromDisposition, parseErrorBody } from '../../web/src/api.js';
import { fractalBody } from '../../web/src/fractals.js';
import { angleDegrees, graspShape, isDrawable } from '../../web/src/grasp_geometry.js';

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
