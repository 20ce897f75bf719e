// bw4t-client: a dependency-free Node.js client for the bw4t protocol (version 1).
// See README.md for usage and ../../PROTOCOL.md for the protocol.

export { connect, Client, ActionHandle } from './src/client.js';
export { PlayerSession, helloOf, joinConflict, MAX_LINE_BYTES } from './src/core.js';
export { Beliefs } from './src/beliefs.js';
export { SINGLE_VALUED, EVENTS, DURATIVE } from './src/table.js';
export { BW4TError, ActionRejected } from './src/errors.js';
