// Errors raised by the client.

/**
 * An error reported by the server (`error` message), or the end of the connection.
 * `code` is the protocol's stable code (`name_taken`, `bad_token`, `unknown_match`,
 * `unknown_template`, `unresponsive`, ...) or one of the client's own:
 * `connection_closed`, `connect_failed`, `timeout`, `match_over`, `not_connected`,
 * `bad_options` (options that cannot go together, such as `match` with `template`).
 */
export class BW4TError extends Error {
  /**
   * @param {string} code
   * @param {string} message
   * @param {{fatal?: boolean, cause?: unknown}} [options]
   */
  constructor(code, message, options = {}) {
    super(`${code}: ${message}`, options.cause === undefined ? undefined : { cause: options.cause });
    this.name = 'BW4TError';
    /** The stable code. */
    this.code = code;
    /** The server's words (or the client's). */
    this.detail = message;
    /** Whether the connection is over because of it. */
    this.fatal = options.fatal ?? true;
  }
}

/**
 * An action the server refused (`ack` with `ok: false`). Raised by a handle's `result`
 * promise; the `ack` promise resolves with the ack itself.
 */
export class ActionRejected extends BW4TError {
  /**
   * @param {string} action
   * @param {{id?: string|number, ok: boolean, tick: number, code?: string, reason?: string}} ack
   */
  constructor(action, ack) {
    super(ack.code ?? 'rejected', `${action} refused: ${ack.reason ?? 'no reason given'}`, { fatal: false });
    this.name = 'ActionRejected';
    /** The rejecting ack. */
    this.ack = ack;
  }
}
