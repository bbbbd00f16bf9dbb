// The mesh panel's 3D view (three.js): the uploaded mesh resting on the table in one of its
// stable poses, with its grasps. The scene is the table frame T of the answer (z up, the table top
// at z = 0); the mesh and its grasps are in the mesh frame O, one group placed by the pose's
// table_from_object. Same controls as the fractal preview (preview.js); loaded with it, lazily.

import {
  BoxGeometry, BufferGeometry, Color, GridHelper, Group, Line, LineBasicMaterial, Mesh,
  MeshBasicMaterial, MeshStandardMaterial, PlaneGeometry, Quaternion, Vector3,
} from 'three';
import { graspInPose, qualityScale } from './mesh_grasps_model.js';
import { MeshPreview } from './preview.js';

const LOW = new Color(0xd7301f); // robust quality: lowest of the answer …
const MID = new Color(0xf0b400);
const HIGH = new Color(0x1a9641); // … highest
const BLOCKED = new Color(0x8c96a0); // not collision-free in the pose shown
const SELECTED = new Color(0xff00ff); // as the grasps panel's selected grasp
const X = new Vector3(1, 0, 0);

function qualityColour(t) {
  return t < 0.5 ? LOW.clone().lerp(MID, t * 2) : MID.clone().lerp(HIGH, (t - 0.5) * 2);
}

const vec = (a) => new Vector3(a[0], a[1], a[2]);
// The answer's poses are {position_m, orientation_wxyz}; three's quaternions are x, y, z, w.
const quat = (q) => new Quaternion(q[1], q[2], q[3], q[0]);

/** Removes a group's children and frees their geometries and materials. */
function clear(group) {
  for (const child of [...group.children]) {
    group.remove(child);
    child.traverse((node) => {
      if (node.geometry) node.geometry.dispose();
      if (node.material) node.material.dispose();
    });
  }
}

/** Grid spacing for an object of bounding radius r: 1, 2 or 5 times a power of ten, 10-25 cells over 4 r. */
export function gridStep(r) {
  const target = (4 * r) / 10;
  const power = 10 ** Math.floor(Math.log10(target));
  const m = target / power;
  return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * power;
}

export class MeshGraspView extends MeshPreview {
  constructor(canvas) {
    super(canvas);
    // See the closing lines through the object.
    this.material.transparent = true;
    this.material.opacity = 0.55;
    this.object = new Group(); // frame O, placed by table_from_object
    this.grasps = new Group();
    this.object.add(this.grasps);
    this.table = new Group();
    this.scene.add(this.object, this.table);
    this.result = null;
    this.pose = -1;
  }

  /** A new mesh (BufferGeometry in metres, frame O) and its analysis. */
  load(geometry, result) {
    if (this.mesh) {
      this.object.remove(this.mesh);
      this.mesh.geometry.dispose();
    }
    if (!geometry.getAttribute('normal')) geometry.computeVertexNormals();
    geometry.computeBoundingSphere();
    this.mesh = new Mesh(geometry, this.material);
    this.object.add(this.mesh);
    this.radius = geometry.boundingSphere.radius > 0 ? geometry.boundingSphere.radius : 0.05;
    this.result = result;
    this.pose = -1;
  }

  /**
   * Shows stable pose `pose` (index into stable_poses) with the first `count` grasps and the
   * `selected` one (index into grasps, -1 for none). A new pose frames the view again.
   */
  update({ pose, count, selected }) {
    const p = this.result.stable_poses[pose];
    if (!p) return;
    const index = p.index ?? pose;
    if (pose !== this.pose) {
      this.object.position.copy(vec(p.table_from_object.position_m));
      this.object.quaternion.copy(quat(p.table_from_object.orientation_wxyz));
      this.object.updateMatrixWorld(true);
      this.center = vec(this.result.center_of_mass_m).applyMatrix4(this.object.matrixWorld);
      this.makeTable();
    }
    this.drawGrasps(index, count, selected);
    if (pose !== this.pose) {
      this.pose = pose;
      this.resetView();
    } else {
      this.render();
    }
  }

  /** A square of table under the centre of mass, about 4 bounding radii wide, with a grid. */
  makeTable() {
    clear(this.table);
    const step = gridStep(this.radius);
    const cells = Math.ceil((4 * this.radius) / step);
    const size = cells * step;
    const top = new Mesh(new PlaneGeometry(size, size),
      new MeshStandardMaterial({ color: 0xd9d2c5, roughness: 0.9 }));
    top.position.set(this.center.x, this.center.y, -this.radius * 2e-3);
    const grid = new GridHelper(size, cells, 0x9a8f7c, 0xb8ae9c);
    grid.rotation.x = Math.PI / 2; // three's grid lies in x-z; the table is x-y
    grid.position.set(this.center.x, this.center.y, -this.radius * 1e-3);
    this.table.add(top, grid);
    this.gridStep = step;
  }

  drawGrasps(pose, count, selected) {
    clear(this.grasps);
    const grasps = this.result.grasps;
    const quality = qualityScale(grasps);
    const jaw = this.radius * 0.16; // jaw markers: square plates at the contacts
    const drawn = grasps.map((g, i) => i).filter((i) => i < count && i !== selected);
    if (grasps[selected]) drawn.push(selected); // last: on top
    for (const i of drawn) {
      const g = grasps[i];
      const seen = graspInPose(g, pose);
      const free = Boolean(seen && seen.collision_free);
      const colour = i === selected ? SELECTED : free ? qualityColour(quality(g)) : BLOCKED;
      const opacity = free || i === selected ? 1 : 0.35;
      const scale = i === selected ? 1.4 : 1;
      const [a, b] = g.contacts.map((c) => vec(c.point_m));
      const line = new Line(new BufferGeometry().setFromPoints([a, b]),
        new LineBasicMaterial({ color: colour, transparent: opacity < 1, opacity }));
      this.grasps.add(line);
      const axis = new Vector3().subVectors(b, a).normalize();
      const turn = new Quaternion().setFromUnitVectors(X, axis);
      for (const [point, outward] of [[a, -1], [b, 1]]) {
        const plate = new Mesh(new BoxGeometry(jaw * 0.25 * scale, jaw * scale, jaw * scale),
          new MeshBasicMaterial({ color: colour, transparent: opacity < 1, opacity }));
        plate.quaternion.copy(turn);
        plate.position.copy(point).addScaledVector(axis, (outward * jaw * 0.125 * scale));
        this.grasps.add(plate);
      }
      if (i === selected && seen && Array.isArray(seen.approach_o)) {
        // Where the gripper comes from: back along the approach, from the grasp centre.
        const centre = vec(g.center_m);
        const back = centre.clone().addScaledVector(vec(seen.approach_o), -this.radius * 1.2);
        this.grasps.add(new Line(new BufferGeometry().setFromPoints([centre, back]),
          new LineBasicMaterial({ color: SELECTED })));
      }
    }
  }
}
