// Small DOM helpers the page's modules share.

// `select`'s options made anew: `first` (value '', a label such as "Recent...") when given, then
// each of `options` ([value, text]).
export function fillSelect(select, first, options) {
  select.textContent = '';
  for (const [value, text] of first === null ? options : [['', first], ...options]) {
    const o = document.createElement('option');
    o.value = value;
    o.textContent = text;
    select.appendChild(o);
  }
}
