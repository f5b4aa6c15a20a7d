// Undo and redo of what the user set: each edit that ends (a slider let go, a number typed, a preset,
// Reset, Randomise, a character opened) commits the face as it now is; undo steps back to the face
// before it, redo forward again. A face is a plain snapshot ({weights, controls, expressions}), so
// stepping back gives the same request, and the same mesh, bit for bit.

export class History {
  constructor(limit = 200) {
    this.limit = limit;
    this.clear(null);
  }

  // Forget every step; `snapshot` is the face as it is now (a rig just loaded).
  clear(snapshot) {
    this.past = [];
    this.future = [];
    this.current = snapshot;
  }

  // The face after an edit: the face before it becomes a step back. Nothing when it did not change.
  commit(snapshot) {
    if (this.current && same(this.current, snapshot)) return false;
    if (this.current) this.past.push(this.current);
    if (this.past.length > this.limit) this.past.shift();
    this.future = [];
    this.current = snapshot;
    return true;
  }

  canUndo() { return this.past.length > 0; }
  canRedo() { return this.future.length > 0; }

  // The face to show after stepping back (or forward), or null when there is none.
  undo() {
    if (!this.past.length) return null;
    this.future.push(this.current);
    this.current = this.past.pop();
    return this.current;
  }

  redo() {
    if (!this.future.length) return null;
    this.past.push(this.current);
    this.current = this.future.pop();
    return this.current;
  }
}

function same(a, b) { return JSON.stringify(a) === JSON.stringify(b); }
