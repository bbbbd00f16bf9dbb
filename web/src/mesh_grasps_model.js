// The mesh panel's logic without the DOM or three.js: the request's query, the scale that puts
// the uploaded file in the answer's frame, and the rows of the pose and grasp tables. The answer
// is POST /v1/meshes/grasps format=json (service/codec/mesh_grasps_json.h); fields it does not
// know are ignored, fields it lacks show as "–".

import { fixed } from './ui.js';

/** The query string: format=json, the unit and every filled-in option; empty ones take the service's defaults. */
export function meshQuery(fields) {
  const query = new URLSearchParams({ format: 'json', unit: fields.unit === 'mm' ? 'mm' : 'm' });
  for (const key of ['num_grasps', 'robust_samples', 'seed', 'friction_coefficient']) {
    if (fields[key] !== undefined) query.set(key, String(fields[key]));
  }
  if (fields.rescale) query.set('rescale_min_extent_mm', '40'); // Dex-Net's object size
  return query.toString();
}

/** What parseMesh needs ('obj', 'ply' or 'stl'): the service's name of the format, else the file's extension. */
export function meshFileFormat(fileName, answerFormat) {
  const named = /^(obj|ply|stl)/i.exec(String(answerFormat || ''));
  if (named) return named[1].toLowerCase();
  const extension = /\.(obj|ply|stl)$/i.exec(String(fileName || ''));
  return extension ? extension[1].toLowerCase() : null;
}

/**
 * Metres in the answer's frame per unit of the file: the service's "scale_applied" (unit times
 * rescale), else what the unit alone gives.
 */
export function meshScale(answerMesh, unit) {
  const scale = answerMesh && (answerMesh.scale_applied ?? answerMesh.scale);
  if (typeof scale === 'number' && Number.isFinite(scale) && scale > 0) return scale;
  return unit === 'mm' ? 0.001 : 1;
}

/** The grasp as seen in stable pose `pose` (its entry of grasp.poses), or null. */
export function graspInPose(grasp, pose) {
  const list = Array.isArray(grasp && grasp.poses) ? grasp.poses : [];
  return list.find((p) => p && p.pose === pose) || null;
}

/** The quality the grasps are ranked and coloured by: robust Ferrari-Canny, else the nominal one. */
export function graspQuality(grasp) {
  const robust = grasp.robust_ferrari_canny;
  return typeof robust === 'number' ? robust : grasp.ferrari_canny;
}

/** Maps a grasp's quality to [0, 1] over the range of all grasps (1 when they are all equal). */
export function qualityScale(grasps) {
  const values = grasps.map(graspQuality).filter((q) => typeof q === 'number' && Number.isFinite(q));
  const low = Math.min(...values);
  const high = Math.max(...values);
  return (grasp) => {
    const q = graspQuality(grasp);
    if (!(high > low) || typeof q !== 'number') return 1;
    return Math.min(1, Math.max(0, (q - low) / (high - low)));
  };
}

const yesNo = (value) => (value === true ? 'yes' : value === false ? 'no' : '–');

/** How many grasps are aligned and collision-free in each pose: the ones a top-down arm can use. */
export function usableCounts(result) {
  return result.stable_poses.map((pose, i) => result.grasps.filter((g) => {
    const seen = graspInPose(g, pose.index ?? i);
    return seen && seen.aligned && seen.collision_free;
  }).length);
}

/** Cells of the pose table: index, probability %, centre of mass height mm, usable grasps. */
export function poseRows(result) {
  const usable = usableCounts(result);
  return result.stable_poses.map((pose, i) => [
    String(pose.index ?? i),
    fixed(pose.probability * 100, 1),
    fixed(pose.com_height_m * 1000, 1),
    String(usable[i]),
  ]);
}

/** Cells of the grasp table in one pose: rank, width mm, robust FC, FC, aligned, collision-free, approach angle. */
export function graspRows(result, pose) {
  return result.grasps.map((g) => {
    const seen = graspInPose(g, pose) || {};
    return [
      String(g.rank),
      fixed(g.width_m * 1000, 1),
      fixed(g.robust_ferrari_canny, 4),
      fixed(g.ferrari_canny, 4),
      yesNo(seen.aligned),
      yesNo(seen.collision_free),
      fixed(seen.approach_table_angle_deg, 1),
    ];
  });
}

/**
 * One line about the upload (the answer's "mesh" object: format, size, unit, rescale, repairs)
 * and the analysis, with the answer's no_grasp message when no grasp is usable.
 */
export function meshSummary(result, fileName) {
  const mesh = result.mesh || {};
  const poses = result.stable_poses.length;
  const grasps = result.grasps.length;
  const parts = [`${fileName}`];
  if (mesh.format) parts.push(`${mesh.format}`);
  if (typeof mesh.triangles === 'number') parts.push(`${mesh.triangles} triangles`);
  if (typeof mesh.vertices === 'number') parts.push(`${mesh.vertices} vertices`);
  const unit = mesh.unit || { 1: 'm', 0.001: 'mm' }[mesh.unit_scale_m];
  if (unit) parts.push(`unit ${unit}`);
  if (typeof mesh.rescale_factor === 'number' && mesh.rescale_factor !== 1) {
    parts.push(`rescaled × ${Number(mesh.rescale_factor.toPrecision(4))}`);
  }
  if (Array.isArray(mesh.extents_m) && mesh.extents_m.length === 3) {
    parts.push(`extents ${mesh.extents_m.map((x) => fixed(x * 1000, 1)).join(' × ')} mm`);
  }
  const repairs = Array.isArray(mesh.repairs) && mesh.repairs.length
    ? ` Repairs: ${mesh.repairs.join('; ')}.` : '';
  const warnings = Array.isArray(mesh.warnings) && mesh.warnings.length
    ? ` Warnings: ${mesh.warnings.join('; ')}.` : '';
  const why = result.no_grasp && typeof result.no_grasp.message === 'string'
    ? ` No usable grasp: ${result.no_grasp.message}.` : '';
  return `${parts.join(', ')}: ${poses} stable pose${poses === 1 ? '' : 's'}, ${grasps} grasp${grasps === 1 ? '' : 's'}`
    + `, ${fixed(result.timing_ms && result.timing_ms.total, 0)} ms.${why}${repairs}${warnings}`;
}

/** A length in metres as text with a fitting unit: "1 cm", "10 cm", "1 m", "5 mm". */
export function lengthText(metres) {
  if (!(metres > 0)) return '';
  if (metres >= 1) return `${Number(metres.toPrecision(3))} m`;
  if (metres >= 0.01) return `${Number((metres * 100).toPrecision(3))} cm`;
  return `${Number((metres * 1000).toPrecision(3))} mm`;
}
