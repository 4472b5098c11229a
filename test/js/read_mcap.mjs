// Read MCAP files with @mcap/core and decode every message with @foxglove/rosmsg2-serialization.
// Usage: node read_mcap.mjs FILE...   Prints one JSON line per message:
// {"topic", "log_time" (ns, string), "message" (decoded, bigints as strings)}.
import { readFileSync } from 'node:fs';
import { McapStreamReader } from '@mcap/core';
import { loadDecompressHandlers } from '@mcap/support';
import { parse } from '@foxglove/rosmsg';
import { MessageReader } from '@foxglove/rosmsg2-serialization';

const handlers = await loadDecompressHandlers();
const replacer = (_k, v) => (typeof v === 'bigint' ? v.toString() : v);

for (const file of process.argv.slice(2)) {
  const reader = new McapStreamReader({ decompressHandlers: handlers, validateCrcs: true });
  reader.append(readFileSync(file));
  const schemas = new Map();
  const channels = new Map();
  for (let rec; (rec = reader.nextRecord()); ) {
    if (rec.type === 'Schema') {
      schemas.set(rec.id, rec);
    } else if (rec.type === 'Channel') {
      const schema = schemas.get(rec.schemaId);
      const text = new TextDecoder().decode(schema.data);
      channels.set(rec.id, { topic: rec.topic,
        reader: new MessageReader(parse(text, { ros2: true })) });
    } else if (rec.type === 'Message') {
      const ch = channels.get(rec.channelId);
      const message = ch.reader.readMessage(rec.data);
      process.stdout.write(JSON.stringify(
        { topic: ch.topic, log_time: rec.logTime.toString(), message }, replacer) + '\n');
    }
  }
  if (!reader.done()) {
    console.error(`${file}: incomplete MCAP file`);
    process.exit(1);
  }
}
