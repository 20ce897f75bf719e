// The WebSocket at /ws: protocol/PROTOCOL.md unchanged, one JSON message per text frame.

import { params } from './dom.js';
import { page } from './page.js';

/** The address of /ws on the server that served the page (`wss:` under HTTPS). */
function socketUrl() {
  return `${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`;
}

/** Opens the WebSocket, says `hello` (a message, or its JSON line) once it is open and
 * hands every server message to onMessage. The contract is one message per text frame;
 * several lines in one frame are accepted too, as the TCP protocol would send them.
 * What is sent before the socket is open, or after it closed, is dropped. */
export function openSocket(hello, onMessage, onClose) {
  const ws = new WebSocket(socketUrl());
  ws.addEventListener('open', () => ws.send(typeof hello === 'string' ? hello : JSON.stringify(hello)));
  ws.addEventListener('message', (event) => {
    if (typeof event.data !== 'string') return;
    for (const line of event.data.split('\n')) {
      if (!line.trim()) continue;
      let message;
      try {
        message = JSON.parse(line);
      } catch {
        console.warn('bw4t: not JSON from the server:', line);
        continue;
      }
      onMessage(message);
    }
  });
  ws.addEventListener('close', (event) => onClose(event));
  const sendLine = (line) => {
    if (ws.readyState === WebSocket.OPEN) ws.send(line);
  };
  return {
    ws,
    send(message) {
      sendLine(JSON.stringify(message));
    },
    sendLine,
    close() {
      ws.close();
    },
  };
}

/** The URL parameter holding each role's credential (PROTOCOL.md, Roles). */
export const TOKEN_PARAMS = { agent: 'token', spectator: 'spectator_token', operator: 'operator_token' };

/** Where the lobby keeps the operator token typed into it, for this tab only. */
export const OPERATOR_TOKEN_KEY = 'bw4t-operator-token';

/** The operator token: `?operator_token=`, else (on a lobby server) the one typed into
 * the lobby in this tab. */
export function operatorToken() {
  return params.get(TOKEN_PARAMS.operator) || (page.lobby ? sessionStorage.getItem(OPERATOR_TOKEN_KEY) : null) || null;
}

/** The credential of a role (`agent`, `spectator`, `operator`) from the page's address
 * (the operator's also from the lobby), or null. */
export function tokenOf(role) {
  return (role === 'operator' ? operatorToken() : params.get(TOKEN_PARAMS[role])) || null;
}

/** A `hello` with the credential of its role, if given. */
export function helloFor(extra) {
  const hello = { type: 'hello', protocol: 'bw4t', versions: [1], ...extra };
  const token = tokenOf(extra.role || 'agent');
  if (token) hello.token = token;
  return hello;
}
