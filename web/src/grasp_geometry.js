// Where a grasp is in the image, for drawing: the same geometry as the service's overlay picture
// (service/io/overlay.cpp). Image coordinates: u right, v down, in pixels; angle_rad turns the
// closing axis from +u towards +v.

const MIN_FINGER_PX = 2; // fingers stay visible on small images, as in the service's overlay

/**
 * The two finger rectangles (4 corners each) and the closing line between them.
 * @param {{center_px: {u: number, v: number}, angle_rad: number, opening_px: number,
 *          finger_width_px: number, finger_thickness_px: number}} grasp
 * @returns {{center: number[], fingers: number[][][], line: number[][]}}
 */
export function graspShape(grasp) {
  const { u, v } = grasp.center_px;
  const axis = [Math.cos(grasp.angle_rad), Math.sin(grasp.angle_rad)];
  const across = [-axis[1], axis[0]];
  const thickness = Math.max(Math.abs(grasp.finger_thickness_px), MIN_FINGER_PX);
  const width = Math.max(Math.abs(grasp.finger_width_px), MIN_FINGER_PX);
  const offset = Math.abs(grasp.opening_px) / 2 + Math.abs(grasp.finger_thickness_px) / 2;
  const fingerAt = (sign) => {
    const c = [u + sign * axis[0] * offset, v + sign * axis[1] * offset];
    const a = [axis[0] * thickness / 2, axis[1] * thickness / 2];
    const b = [across[0] * width / 2, across[1] * width / 2];
    return [
      [c[0] - a[0] - b[0], c[1] - a[1] - b[1]],
      [c[0] + a[0] - b[0], c[1] + a[1] - b[1]],
      [c[0] + a[0] + b[0], c[1] + a[1] + b[1]],
      [c[0] - a[0] + b[0], c[1] - a[1] + b[1]],
    ];
  };
  const fingers = [fingerAt(-1), fingerAt(+1)];
  const centreOf = (corners) => [
    corners.reduce((s, p) => s + p[0], 0) / 4,
    corners.reduce((s, p) => s + p[1], 0) / 4,
  ];
  return { center: [u, v], fingers, line: [centreOf(fingers[0]), centreOf(fingers[1])] };
}

/** Whether a grasp can be drawn (finite, within a sane range), as the service checks. */
export function isDrawable(grasp) {
  const values = [grasp.center_px && grasp.center_px.u, grasp.center_px && grasp.center_px.v,
    grasp.angle_rad, grasp.opening_px, grasp.finger_width_px, grasp.finger_thickness_px];
  return values.every((x) => typeof x === 'number' && Number.isFinite(x) && Math.abs(x) < 1e6);
}

/** Rotation angle of the closing axis in degrees in [0, 180), for the table. */
export function angleDegrees(angleRad) {
  const deg = (angleRad * 180) / Math.PI;
  return ((deg % 180) + 180) % 180;
}
