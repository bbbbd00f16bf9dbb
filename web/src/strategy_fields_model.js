// The selected strategy's own request fields, as GET /v1/info's `strategy_fields` lists them (the
// table each strategy's room keeps in the service): what the grasps panel builds its inputs from.
// Pure: no DOM.

/** "max_press_depth_mm" with unit "mm" -> "Max press depth (mm)". */
export function fieldLabel(field) {
  let words = String(field.name || '');
  if (field.unit && words.endsWith(`_${field.unit}`)) words = words.slice(0, -field.unit.length - 1);
  words = words.replace(/_/g, ' ');
  const text = words.charAt(0).toUpperCase() + words.slice(1);
  return field.unit ? `${text} (${field.unit})` : text;
}

/** A field's default as the form shows it: a number, a choice, or "0.5,0.75,1". */
function defaultText(field) {
  if (Array.isArray(field.default)) return field.default.join(',');
  return field.default === undefined || field.default === null ? '' : String(field.default);
}

/**
 * The inputs for `strategy`'s fields, in the table's order: {name, label, doc, input: 'select' |
 * 'number' | 'text', options (select), min, max, step (number), defaultText}. Unknown kinds and
 * malformed rows are left out; no info or no such strategy gives none.
 */
export function strategyFieldInputs(info, strategy) {
  const tables = info && Array.isArray(info.strategy_fields) ? info.strategy_fields : [];
  const table = tables.find((t) => t && t.name === strategy);
  if (!table || !Array.isArray(table.fields)) return [];
  const out = [];
  for (const field of table.fields) {
    if (!field || typeof field.name !== 'string' || field.name === '') continue;
    const base = { name: field.name, label: fieldLabel(field), doc: field.doc || '',
      defaultText: defaultText(field) };
    if (field.kind === 'choice' && Array.isArray(field.choices)) {
      out.push({ ...base, input: 'select', options: field.choices.map(String) });
    } else if (field.kind === 'number' || field.kind === 'integer') {
      out.push({ ...base, input: 'number', min: field.minimum, max: field.maximum,
        step: field.kind === 'integer' ? '1' : 'any' });
    } else if (field.kind === 'number_list') {
      out.push({ ...base, input: 'text' });
    }
  }
  return out;
}
