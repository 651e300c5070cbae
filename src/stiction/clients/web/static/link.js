// The WebSocket to the bridge: reconnects with backoff, hands each parsed
// message to a callback. Nothing is queued here: the bridge already sends only
// the latest state, and the page keeps only the latest of each stream.

export function connect(url, { onMessage, onOpen, onClose }) {
  let delay = 250;
  let ws = null;
  const open = () => {
    ws = new WebSocket(url);
    ws.onopen = () => { delay = 250; onOpen(); };
    ws.onmessage = (ev) => {
      let msg;
      try { msg = JSON.parse(ev.data); } catch (err) { console.warn("bad message", err); return; }
      onMessage(msg, performance.now());
    };
    ws.onclose = () => {
      onClose(delay);
      setTimeout(open, delay);
      delay = Math.min(delay * 2, 4000);
    };
  };
  open();
  return () => ws && ws.close();
}
