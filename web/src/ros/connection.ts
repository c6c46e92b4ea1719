// The page's link to a rosbridge server (roslibjs): connection status, reconnection
// with exponential backoff, a URL that can be changed at run time, and typed service
// calls and subscriptions over the generated message types (generated/msgs.ts).

import { Ros, Service, Topic } from "roslib";
import { SERVICES, TOPICS, type MessageTypes, type ServiceTypes } from "../generated/msgs";

export type ConnectionStatus = "connecting" | "connected" | "disconnected";

export interface ConnectionState {
  status: ConnectionStatus;
  /** The rosbridge WebSocket URL in use. */
  url: string;
  /** Why the last attempt failed or the link dropped, or null. */
  error: string | null;
  /** Failed attempts since the last success. */
  attempts: number;
  /** When the next attempt is due (ms since the epoch), or null. */
  retryAt: number | null;
}

type TopicName = keyof typeof TOPICS;

/** How the server sends a fast topic to a slow page: at most `queueLength` messages
 * waiting (rosbridge `queue_length`; older ones are dropped); `cbor`: binary frames
 * (numeric arrays arrive as typed arrays, far quicker to decode than JSON). */
export interface SubscribeRate {
  queueLength?: number;
  cbor?: boolean;
}
type TopicMessage<N extends TopicName> = MessageTypes[(typeof TOPICS)[N]];
type ServiceName = keyof typeof SERVICES;
type Call<N extends ServiceName> = ServiceTypes[(typeof SERVICES)[N]];

const FIRST_RETRY_MS = 500;
const LONGEST_RETRY_MS = 10_000;

/** The token the page was opened with (`?token=`), for a server started with one. */
export function pageToken(): string | null {
  return new URLSearchParams(location.search).get("token");
}

/** The WebSocket URL of a rosbridge path on the server that sent the page (with the
 * page's token, if it has one). */
export function sameOriginUrl(path: string): string {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  const token = pageToken();
  const query = token ? `?token=${encodeURIComponent(token)}` : "";
  return `${scheme}//${location.host}${path}${query}`;
}

/** Check a rosbridge URL typed by a user; the URL, or an error saying what is wrong. */
export function checkRosbridgeUrl(text: string): string {
  const url = text.trim();
  let parsed: URL;
  try {
    parsed = new URL(url);
  } catch {
    throw new Error(`"${url}" is not a URL; a rosbridge address looks like ws://host:9090`);
  }
  if (parsed.protocol !== "ws:" && parsed.protocol !== "wss:") {
    throw new Error(`"${url}" must start with ws:// or wss:// (rosbridge is a WebSocket)`);
  }
  return url;
}

/** One rosbridge connection that keeps itself up: after a drop it retries after 0.5 s,
 * then 1, 2, 4, 8 and at most 10 s between attempts, until `close()` or a new URL. */
export class RosConnection {
  private ros: Ros | null = null;
  private url = "";
  private status: ConnectionStatus = "disconnected";
  private error: string | null = null;
  private attempts = 0;
  private retryAt: number | null = null;
  private retryTimer: number | undefined;
  /** Subscriptions to restore on every new connection. */
  private readonly subscriptions = new Set<{
    name: string;
    type: string;
    cb: (m: never) => void;
    rate?: SubscribeRate;
  }>();
  private readonly live = new Map<object, Topic<unknown>>();
  /** Topics this page publishes on, per name (re-created on a new connection). */
  private readonly publishers = new Map<string, Topic<unknown>>();
  private readonly listeners = new Set<(state: ConnectionState) => void>();
  /** Service calls waiting for an answer: failed at once when the connection drops. */
  private readonly pending = new Set<(error: Error) => void>();

  /** Connect to `url` (dropping any current connection). */
  open(url: string): void {
    this.shutdown();
    this.url = url;
    this.attempts = 0;
    this.error = null;
    this.attempt();
  }

  /** Disconnect and stop retrying. */
  close(): void {
    this.shutdown();
    this.set("disconnected");
  }

  state(): ConnectionState {
    return {
      status: this.status,
      url: this.url,
      error: this.error,
      attempts: this.attempts,
      retryAt: this.retryAt,
    };
  }

  /** Call `listener` on every status change (and once now). */
  onChange(listener: (state: ConnectionState) => void): void {
    this.listeners.add(listener);
    listener(this.state());
  }

  /** Call a platform service (`at`: where it is offered when not at `name`, as another
   * robot's PlanTask); rejects with the server's message when it fails. */
  call<N extends ServiceName>(
    name: N,
    request: Call<N>["request"],
    timeoutMs = 60_000,
    at: string = name,
  ): Promise<Call<N>["response"]> {
    const ros = this.ros;
    if (!ros || this.status !== "connected") {
      return Promise.reject(new Error(`not connected to rosbridge (${this.url})`));
    }
    const service = new Service<Call<N>["request"], Call<N>["response"]>({
      ros,
      name: at,
      serviceType: SERVICES[name],
    });
    return new Promise((resolve, reject) => {
      const fail = (error: Error) => {
        this.pending.delete(fail);
        reject(error);
      };
      this.pending.add(fail);
      service.callService(
        request,
        (response) => {
          this.pending.delete(fail);
          resolve(response);
        },
        (error) => fail(new Error(`${name}: ${error}`)),
        timeoutMs,
      );
    });
  }

  /** Receive a platform topic, now and after every reconnection; `rate` lets the
   * server thin out a fast topic for a slow page. */
  subscribe<N extends TopicName>(
    name: N,
    callback: (msg: TopicMessage<N>) => void,
    rate?: SubscribeRate,
  ): void {
    const entry = {
      name,
      type: TOPICS[name] as string,
      cb: callback as (m: never) => void,
      rate,
    };
    this.subscriptions.add(entry);
    if (this.ros && this.status === "connected") this.listen(this.ros, entry);
  }

  /** Send `message` on a platform topic (advertised on first use); false when not
   * connected. */
  publish<N extends TopicName>(name: N, message: TopicMessage<N>): boolean {
    const ros = this.ros;
    if (!ros || this.status !== "connected") return false;
    let topic = this.publishers.get(name);
    if (!topic || topic.ros !== ros) {
      topic = new Topic<unknown>({ ros, name, messageType: TOPICS[name] });
      this.publishers.set(name, topic);
    }
    topic.publish(message);
    return true;
  }

  private attempt(): void {
    this.retryAt = null;
    this.set("connecting");
    const ros = new Ros({});
    this.ros = ros;
    ros.on("connection", () => {
      if (ros !== this.ros) return;
      this.attempts = 0;
      this.error = null;
      for (const entry of this.subscriptions) this.listen(ros, entry);
      // From the page's start: with "robotrial:ready", how long until the page is usable.
      performance.measure(`robotrial:connected ${this.url}`);
      this.set("connected");
    });
    ros.on("error", () => {
      if (ros === this.ros) this.error = `could not reach ${this.url}`;
    });
    ros.on("close", () => {
      if (ros !== this.ros) return;
      if (this.status === "connected") this.error = "the connection dropped";
      this.retry();
    });
    ros.connect(this.url).catch((err: unknown) => {
      if (ros !== this.ros) return;
      this.error = err instanceof Error ? err.message : String(err);
      this.retry();
    });
  }

  private retry(): void {
    if (this.retryTimer !== undefined) return;
    this.failPending();
    this.live.clear();
    this.publishers.clear();
    this.attempts += 1;
    const delay = Math.min(LONGEST_RETRY_MS, FIRST_RETRY_MS * 2 ** (this.attempts - 1));
    this.retryAt = Date.now() + delay;
    this.set("disconnected");
    this.retryTimer = window.setTimeout(() => {
      this.retryTimer = undefined;
      this.attempt();
    }, delay);
  }

  private listen(
    ros: Ros,
    entry: { name: string; type: string; cb: (m: never) => void; rate?: SubscribeRate },
  ): void {
    const topic = new Topic<unknown>({
      ros,
      name: entry.name,
      messageType: entry.type,
      queue_length: entry.rate?.queueLength ?? 0,
      compression: entry.rate?.cbor ? "cbor" : "none",
    });
    topic.subscribe(entry.cb as (m: unknown) => void);
    this.live.set(entry, topic);
  }

  private failPending(): void {
    const error = new Error(`the connection to ${this.url} dropped before the answer came`);
    for (const fail of [...this.pending]) fail(error);
  }

  private shutdown(): void {
    window.clearTimeout(this.retryTimer);
    this.retryTimer = undefined;
    this.retryAt = null;
    const ros = this.ros;
    this.ros = null;
    this.failPending();
    this.live.clear();
    this.publishers.clear();
    ros?.close();
  }

  private set(status: ConnectionStatus): void {
    this.status = status;
    const state = this.state();
    for (const listener of this.listeners) listener(state);
  }
}
