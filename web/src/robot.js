// The robot panel: the robots on the bus (GET /v1/robot), and forwarding the grasp picked in the
// grasps table to one of them (POST /v1/robot/grasps with the bearer token), then following the
// command by polling its Location until a final state, and showing the robot's result.
//
// The token lives only in the password field (this page's memory): nothing is stored, so a
// reload asks for it again, and it is sent only to this page's own origin.

import { ApiError, call, describeError } from './api.js';
import { GRASP_SELECTED_EVENT } from './grasps.js';
import {
  commandUrl, describeRobotError, isFinalState, newCommandId, resultSummary, robotCommandBody,
  stateSteps,
} from './robot_model.js';
import { clearError, fixed, numberField, showError, whileBusy } from './ui.js';

const POLL_MS = 250; // results come within tens of ms on loopback; a person sees no lag at 250
const REQUEST_TIMEOUT_MS = 15_000;
const MAX_POLL_FAILURES = 5; // network blips while following a command are retried this often
const DEADLINE_MARGIN_S = 15; // beyond the service's own command timeout, which ends in timed_out

const STATE_TEXT = {
  queued: 'queued (journaled; the service retries writing it on the bus)',
  sent: 'sent to the robot',
  executing: 'executing on the robot',
  succeeded: 'succeeded',
  failed: 'failed',
  rejected: 'rejected by the robot (nothing moved)',
  timed_out: 'timed out (no result in time; withdrawn from the bus)',
  result: 'result',
};

const sleep = (ms) => new Promise((resolve) => { setTimeout(resolve, ms); });

function authHeaders(token) {
  return { Authorization: `Bearer ${token}` };
}

function cell(text, className) {
  const td = document.createElement('td');
  td.textContent = text;
  if (className) td.className = className;
  return td;
}

/** Fills the robots table and the "send to" choice, keeping the choice when it is still listed. */
function showRobots(root, list) {
  const tbody = root.querySelector('#robot-list tbody');
  const target = root.querySelector('#robot-target');
  const robots = (list && list.robots) || [];
  tbody.replaceChildren();
  for (const r of robots) {
    const row = document.createElement('tr');
    row.dataset.robotId = r.robot_id;
    const kind = cell(r.simulated ? 'SIMULATED' : 'real', r.simulated ? 'tag simulated' : 'tag');
    row.append(cell(r.robot_id), kind, cell(r.state), cell(r.alive ? 'yes' : 'no'),
      cell(`${fixed(r.heartbeat_age_s, 1)} s ago`, 'num'));
    tbody.append(row);
  }
  const alive = robots.filter((r) => r.alive).length;
  root.querySelector('#robot-list-status').textContent = robots.length
    ? `${robots.length} robot${robots.length === 1 ? '' : 's'} heard, ${alive} alive.`
    : 'No robot heard on the bus yet.';
  const chosen = target.value;
  const automatic = target.options[0];
  target.replaceChildren(automatic);
  for (const r of robots) {
    const option = document.createElement('option');
    option.value = r.robot_id;
    option.textContent = `${r.robot_id}${r.simulated ? ' (SIMULATED)' : ''}${r.alive ? '' : ' – not alive'}`;
    target.append(option);
  }
  target.value = robots.some((r) => r.robot_id === chosen) ? chosen : '';
  const force = root.querySelector('#robot-force');
  if (list && typeof list.default_force_n === 'number') {
    force.placeholder = `service default: ${list.default_force_n} N`;
  }
}

function selectionText(selection) {
  const g = selection && selection.grasp;
  if (!g) return 'No grasp selected: find grasps above and pick one in the table.';
  const p = (g.pose && g.pose.position_m) || [];
  const frame = (g.pose && g.pose.frame) || 'camera';
  const where = p.length === 3 ? ` at (${p.map((x) => fixed(x * 1000, 1)).join(', ')}) mm, ${frame} frame` : '';
  const from = selection.source ? ` of ${selection.source}` : '';
  return `Selected: grasp ${g.rank}${from}, score ${fixed(g.score, 3)}, opening ${fixed(g.opening_m * 1000, 1)} mm${where}.`;
}

function showSteps(list, seen, current) {
  list.replaceChildren();
  const steps = stateSteps(seen);
  const reached = steps.indexOf(current);
  steps.forEach((step, i) => {
    const item = document.createElement('li');
    item.dataset.state = step;
    item.textContent = step === 'result' ? 'result' : step.replace('_', ' ');
    if (i < reached) item.className = 'done';
    else if (i === reached) {
      item.className = isFinalState(step) ? `current final ${step}` : 'current';
      item.setAttribute('aria-current', 'step');
    }
    list.append(item);
  });
}

function definition(dl, term, value, key) {
  const dt = document.createElement('dt');
  dt.textContent = term;
  const dd = document.createElement('dd');
  dd.textContent = value;
  dd.dataset.field = key;
  dl.append(dt, dd);
}

function showResult(dl, command) {
  dl.replaceChildren();
  const r = resultSummary(command.result);
  if (!r) {
    dl.hidden = true;
    return;
  }
  const mm = (x) => (x === null ? '– (no contact)' : `${x.toFixed(2)} mm`);
  definition(dl, 'Outcome', r.late ? `${r.outcome} (arrived after the timeout)` : r.outcome, 'outcome');
  definition(dl, 'Reason', r.reason || '–', 'reason');
  definition(dl, 'Robot', r.robotId || command.robot_id || '–', 'robot');
  definition(dl, 'Contact width l_c', mm(r.contactWidthMm), 'contact_width');
  definition(dl, 'Grasped width l_g', mm(r.graspedWidthMm), 'grasped_width');
  definition(dl, 'Deformation rate', r.deformationPercent === null ? '–' : `${r.deformationPercent.toFixed(1)} %`,
    'deformation_rate');
  definition(dl, 'Damaged (> 20 %)', r.damaged === null ? '–' : r.damaged ? 'yes' : 'no', 'damaged');
  definition(dl, 'Execution', r.executionS === null ? '–' : `${(r.executionS * 1000).toFixed(0)} ms`, 'execution');
  definition(dl, 'Round trip', r.roundTripS === null ? '–' : `${(r.roundTripS * 1000).toFixed(0)} ms`, 'round_trip');
  dl.hidden = false;
}

export function mountRobotPanel(root, info) {
  const robotInfo = info && info.robot;
  // A service without robot routes (or unreachable): nothing to show.
  if (!robotInfo) return;
  const nav = document.getElementById('robot-nav');
  root.hidden = false;
  if (nav) nav.hidden = false;
  if (!robotInfo.enabled) {
    const note = root.querySelector('#robot-disabled');
    note.textContent = `The robot endpoints are off: ${robotInfo.reason || 'disabled in the configuration'}.`;
    note.hidden = false;
    root.querySelector('#robot-body').hidden = true;
    root.dataset.state = 'disabled';
    return;
  }

  const form = root.querySelector('#robot-form');
  const tokenInput = root.querySelector('#robot-token');
  const target = root.querySelector('#robot-target');
  const forceInput = root.querySelector('#robot-force');
  const selectionLine = root.querySelector('#robot-selection');
  const progress = root.querySelector('#robot-progress');
  const errorBox = root.querySelector('#robot-error');
  const results = root.querySelector('#robot-results');
  const commandLine = root.querySelector('#robot-command');
  const steps = root.querySelector('#robot-steps');
  const stateLine = root.querySelector('#robot-state');
  const resultList = root.querySelector('#robot-result');
  const listStatus = root.querySelector('#robot-list-status');

  let selection = null;
  let commandTimeoutS = 60;
  // An id whose POST got no definite answer (network failure, 5xx other than 503): forwarding
  // the same grasp again reuses it, so the service's idempotency keeps the robot from moving twice.
  let uncertain = null;

  const refresh = async () => {
    try {
      const list = await (await call('/v1/robot', {}, REQUEST_TIMEOUT_MS)).json();
      if (typeof list.command_timeout_s === 'number') commandTimeoutS = list.command_timeout_s;
      showRobots(root, list);
    } catch (error) {
      listStatus.textContent = `Could not list the robots: ${describeError(error)}`;
    }
  };
  root.querySelector('#robot-refresh').addEventListener('click', refresh);

  document.addEventListener(GRASP_SELECTED_EVENT, (event) => {
    selection = event.detail;
    selectionLine.textContent = selectionText(selection);
  });

  const showCommand = (command, seen) => {
    if (!seen.includes(command.state)) seen.push(command.state);
    showSteps(steps, seen, command.state);
    const detail = command.detail ? ` – ${command.detail}` : '';
    stateLine.textContent = `State: ${STATE_TEXT[command.state] || command.state}${detail}`;
    stateLine.dataset.state = command.state;
    showResult(resultList, command);
    root.dataset.state = command.state;
  };

  /** Polls the command until it is final; stops on answers that polling again cannot change. */
  const follow = async (url, token, seen) => {
    const deadline = performance.now() + (commandTimeoutS + DEADLINE_MARGIN_S) * 1000;
    let failures = 0;
    for (;;) {
      await sleep(POLL_MS);
      try {
        const command = await (await call(url, { headers: authHeaders(token), cache: 'no-store' },
          REQUEST_TIMEOUT_MS)).json();
        failures = 0;
        showCommand(command, seen);
        if (isFinalState(command.state)) return command;
      } catch (error) {
        const transient = !(error instanceof ApiError) || error.status === 0 || error.status >= 500;
        failures += 1;
        if (!transient || failures >= MAX_POLL_FAILURES) throw error;
      }
      if (performance.now() > deadline) {
        throw new Error(`no final state within ${commandTimeoutS + DEADLINE_MARGIN_S} s; ` +
          `the command may still finish: ${url}`);
      }
    }
  };

  form.addEventListener('submit', async (event) => {
    event.preventDefault();
    clearError(errorBox);
    const token = tokenInput.value.trim();
    if (!token) {
      showError(errorBox, 'Enter the robot token first (robot.tokens of the service).');
      tokenInput.focus();
      return;
    }
    if (!selection || !selection.grasp) {
      showError(errorBox, 'Pick a grasp first: find grasps in the panel above and select one in the table.');
      return;
    }
    const forceN = numberField(forceInput);
    if (Number.isNaN(forceN)) {
      showError(errorBox, 'The closing force must be a number of newtons, or empty for the default.');
      forceInput.focus();
      return;
    }
    const { grasp } = selection; // the selection may change while the command runs
    const options = { robotId: target.value, forceN };
    const key = JSON.stringify([grasp, options]);
    const id = uncertain && uncertain.key === key ? uncertain.id : newCommandId();
    const body = robotCommandBody(grasp, id, options);
    const seen = [];
    try {
      await whileBusy(form, progress, async () => {
        let response;
        try {
          response = await call('/v1/robot/grasps', {
            method: 'POST',
            headers: { ...authHeaders(token), 'Content-Type': 'application/json' },
            body: JSON.stringify(body),
          }, REQUEST_TIMEOUT_MS);
        } catch (error) {
          const definite = error instanceof ApiError && error.status >= 400
            && (error.status < 500 || error.status === 503);
          uncertain = definite ? null : { key, id };
          throw error;
        }
        uncertain = null;
        const accepted = await response.json();
        commandLine.textContent = `Command ${id} for grasp ${grasp.rank}` +
          `${response.status === 200 ? ' (sent before: the command as it stands)' : ''}`;
        results.hidden = false;
        showCommand(accepted, seen);
        if (!isFinalState(accepted.state)) {
          await follow(commandUrl(response.headers.get('Location'), id), token, seen);
        }
      });
      refresh(); // the robot is idle again, its heartbeat fresh
    } catch (error) {
      root.dataset.state = 'error';
      showError(errorBox, describeRobotError(error));
    }
  });

  refresh();
}
