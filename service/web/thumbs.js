// Small pictures of what each shape and each expression does, for sliders and presets: the service
// draws them as contact sheets (POST /v1/rigs/{id}/sheet, a few cells at a time, no labels), and each
// picture is its cell of a sheet shown as a sprite (a CSS background offset), so a rig's 200 shapes
// are a dozen requests, not 200.

export const kCell = 64;  // Pixels a side of a rendered cell.
const kPad = 4, kLabelBand = 18;  // The sheet's layout (render's ContactSheet): padding, the label band under a cell.
const kColumns = 8;
export const kChunk = 16;  // Cells per sheet: within an anonymous request's CPU budget on a 50k-vertex rig.

// Where cell i of a sheet of `count` cells lies: {x, y} in its pixels, and the sheet's size.
export function cellBox(i, count) {
  const columns = Math.min(kColumns, count);
  const rows = Math.ceil(count / columns);
  return {
    x: kPad + (i % columns) * (kCell + kPad),
    y: kPad + Math.floor(i / columns) * (kCell + kLabelBand + kPad),
    sheetW: columns * (kCell + kPad) + kPad,
    sheetH: rows * (kCell + kLabelBand + kPad) + kPad,
  };
}

// `el` shows cell i of the sheet at `url` at `size` pixels a side.
export function showCell(el, url, i, count, size) {
  const b = cellBox(i, count);
  const k = size / kCell;
  el.style.backgroundImage = `url(${url})`;
  el.style.backgroundSize = `${b.sheetW * k}px ${b.sheetH * k}px`;
  el.style.backgroundPosition = `${-b.x * k}px ${-b.y * k}px`;
  el.classList.add('loaded');
}

// The sheets' object URLs, let go when the pictures of another rig replace them (releaseSheets).
const sheetUrls = [];
export function releaseSheets() {
  for (const url of sheetUrls.splice(0)) URL.revokeObjectURL(url);
}

// Sheets for `items` ({weights}: the face each shows), kChunk cells at a time, one request after the
// other; onSheet(url, first, count) for each that arrives. Stops when stillWanted() turns false (another
// rig picked); a failed sheet is skipped (its pictures stay blank).
export async function loadSheets(post, rigPath, items, settings, onSheet, stillWanted) {
  for (let first = 0; first < items.length; first += kChunk) {
    if (!stillWanted()) return;
    const chunk = items.slice(first, first + kChunk);
    try {
      const r = await post(`${rigPath}/sheet`, {
        ...settings, cells: chunk.map((it) => ({ weights: it.weights, label: '' })), columns: kColumns, width: kCell, height: kCell,
      });
      if (!stillWanted()) return;
      const url = URL.createObjectURL(await r.blob());
      sheetUrls.push(url);
      onSheet(url, first, chunk.length);
    } catch (e) { /* A sheet refused or lost: those pictures stay blank, the sliders work as ever. */ }
  }
}
