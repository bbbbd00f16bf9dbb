// What the grasps panel needs to know about the service's stiffness model, from GET /v1/info:
// whether one is loaded, which strategies to offer and which to preselect, and how the table
// writes a grasp's mean stiffness. Pure functions (no DOM), tested in tests/web/unit.test.mjs.

/** The loaded stiffness model ({name, kind, input_size, ...}), or null without one. */
export function stiffnessModel(info) {
  const models = info && Array.isArray(info.models) ? info.models : [];
  return models.find((m) => m && m.kind === 'stiffness' && typeof m.name === 'string') || null;
}

const STRATEGY_LABELS = {
  fge: 'FGE (fast graspability evaluation)',
  gqcnn: 'GQ-CNN (Dex-Net 2.0 policy)',
  stiffness: 'Stiffness-aware',
  deformability: 'Deformability-aware (one target object)',
};

/**
 * The strategies to offer and the one to preselect: `info.strategies` in the service's order,
 * `info.default_strategy` when it is one of them (else the first). Without info: FGE only.
 * @returns {{options: {value: string, label: string}[], selected: string}}
 */
export function strategyChoices(info) {
  const listed = info && Array.isArray(info.strategies)
    ? info.strategies.filter((s) => typeof s === 'string' && s !== '') : [];
  const names = listed.length ? [...new Set(listed)] : ['fge'];
  const wanted = info && info.default_strategy;
  return {
    options: names.map((value) => ({ value, label: STRATEGY_LABELS[value] || value })),
    selected: names.includes(wanted) ? wanted : names[0],
  };
}

/** A grasp's mean stiffness for the table: 2 decimals, an en dash when null (no model). */
export function meanStiffnessText(value) {
  return typeof value === 'number' && Number.isFinite(value) ? value.toFixed(2) : '–';
}

/** The /v1/stiffness request for the same depth and intrinsics as a grasps request. */
export function stiffnessForm(graspsForm, format = 'color') {
  const form = new FormData();
  for (const name of ['depth', 'intrinsics', 'fx', 'fy', 'cx', 'cy', 'png_unit_m']) {
    const value = graspsForm.get(name);
    if (value !== null) form.append(name, value);
  }
  form.append('format', format);
  return form;
}
