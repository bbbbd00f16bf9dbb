// The robot panel's logic without the DOM (tested under node): the command body, ids, states,
// the result's numbers and the messages for the robot routes' error answers (docs/robot-api.md).

import { ApiError, describeError } from './api.js';

/** States after which a command does not change any more (GET /v1/robot/grasps/{id}). */
export const FINAL_STATES = Object.freeze(['succeeded', 'failed', 'rejected', 'timed_out']);

/** The order a command moves through; `queued` only when writing on the bus failed. */
export const STATE_ORDER = Object.freeze(['queued', 'sent', 'executing']);

/** A deformation rate above this is damage (the simulator's and the thesis' 20 %). */
export const DAMAGE_RATE = 0.2;

const ID_PATTERN = /^[A-Za-z0-9._-]{1,64}$/;

export function isFinalState(state) {
  return FINAL_STATES.includes(state);
}

/**
 * A fresh command id, `web-` and 32 hex digits. getRandomValues, not randomUUID: randomUUID
 * exists only in secure contexts, and the page may be opened over plain http on a LAN address.
 */
export function newCommandId(randomBytes = (bytes) => globalThis.crypto.getRandomValues(bytes)) {
  const bytes = randomBytes(new Uint8Array(16));
  const hex = Array.from(bytes, (b) => b.toString(16).padStart(2, '0')).join('');
  return `web-${hex}`;
}

export function isValidCommandId(id) {
  return typeof id === 'string' && ID_PATTERN.test(id);
}

/**
 * The POST /v1/robot/grasps body: the grasp exactly as /v1/grasps returned it, plus the id and,
 * when given, the robot and the closing force (the service fills in the rest).
 */
export function robotCommandBody(grasp, id, { robotId = '', forceN } = {}) {
  if (!grasp || typeof grasp !== 'object') throw new TypeError('no grasp selected');
  if (!isValidCommandId(id)) throw new TypeError(`bad command id ${id}`);
  const body = { ...grasp, id };
  if (robotId) body.robot_id = robotId;
  if (typeof forceN === 'number' && !Number.isNaN(forceN)) body.force_n = forceN;
  return body;
}

/** The Location of an accepted command, or the route it names when the header is missing. */
export function commandUrl(location, id) {
  if (location && location.startsWith('/v1/robot/grasps/')) return location;
  return `/v1/robot/grasps/${encodeURIComponent(id)}`;
}

/** The states to show as steps: the usual path, then the final state reached (if any). */
export function stateSteps(seen) {
  const steps = STATE_ORDER.filter((s) => s !== 'queued' || seen.includes('queued'));
  const final = seen.find(isFinalState);
  return [...steps, final || 'result'];
}

/** A result's numbers for people: millimetres and percent, and whether the object was damaged. */
export function resultSummary(result) {
  if (!result || typeof result !== 'object') return null;
  const num = (x) => (typeof x === 'number' && Number.isFinite(x) ? x : null);
  const lc = num(result.contact_width_m);
  const lg = num(result.grasped_width_m);
  const rate = num(result.deformation_rate);
  // The robot reports zeros when the fingers touched nothing: then there is no deformation.
  const touched = lc !== null && lc > 0;
  return {
    outcome: String(result.outcome || ''),
    reason: String(result.reason || ''),
    robotId: String(result.robot_id || ''),
    contactWidthMm: touched ? lc * 1000 : null,
    graspedWidthMm: touched && lg !== null ? lg * 1000 : null,
    deformationPercent: touched && rate !== null ? rate * 100 : null,
    damaged: touched && rate !== null ? rate > DAMAGE_RATE : null,
    executionS: num(result.execution_s),
    roundTripS: num(result.round_trip_s),
    late: result.late === true,
  };
}

const STATUS_PREFIX = {
  401: 'The robot routes need a token',
  403: 'Token refused',
  409: 'This command id was already used for another grasp',
  422: 'The service will not send this grasp',
  503: 'No robot can take it now',
};

/** The API's own message, after a short phrase saying what the status means for the person. */
export function describeRobotError(error) {
  if (!(error instanceof ApiError)) return describeError(error);
  const prefix = STATUS_PREFIX[error.status];
  let text = prefix ? `${prefix}: ${describeError(error)}` : describeError(error);
  if (error.status === 503 && error.retryAfterS) text += ` (try again in ${error.retryAfterS} s)`;
  return text;
}
