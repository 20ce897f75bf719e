// Small helpers for the document and the server: the page's address parameters, finding
// and making elements, fetching JSON.

/** The page's address parameters (`?match=`, `?play=`, the tokens, the replay's `tick` and `speed`). */
export const params = new URLSearchParams(location.search);

export const $ = (selector) => document.querySelector(selector);

/** Makes an element: el('li', {class: 'x', dataset: {id: 1}}, 'text', child). */
export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (key === 'dataset') Object.assign(node.dataset, value);
    else if (key === 'style') node.style.cssText = value;
    else if (key.startsWith('on')) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value);
  }
  node.append(...children);
  return node;
}

/** Sets an element's text only when it differs: the panels are refreshed per frame and
 * rewriting unchanged text would still cost style and layout work. */
export function setText(node, text) {
  const s = String(text);
  if (node.textContent !== s) node.textContent = s;
}

/** The credentials a page's address may carry, kept in links to the page's other views. */
const CREDENTIAL_PARAMS = ['token', 'spectator_token', 'operator_token'];

/** The address of another view of this page: this address's credentials plus `changes`
 * (say `{match: 'team-a'}` or `{template: 'ladder', play: 'Ann'}`). */
export function linkTo(changes = {}) {
  const next = new URLSearchParams();
  for (const key of CREDENTIAL_PARAMS) if (params.has(key)) next.set(key, params.get(key));
  for (const [key, value] of Object.entries(changes)) if (value) next.set(key, value);
  const query = next.toString();
  return query ? `/?${query}` : '/';
}

export async function fetchJSON(url) {
  const response = await fetch(url, { cache: 'no-store' });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.json();
}
