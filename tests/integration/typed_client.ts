// A client typed from the server's own /openapi.json: openapi-typescript (its default options) makes
// api.d.ts from the document, `tsc --strict` compiles this file against it, and node runs it on the
// real server. Ten operations: mesh, render, sheet, speech, batch, manifest GET and PUT, rig, check,
// fit. A member the document lacks, or a default typed as required, fails the compile; an answer
// that is not what the types say fails the run.
// usage (compiled): node typed_client.js SERVICE_URL API_KEY
import createClient from 'openapi-fetch';
import type { components, paths } from './api';

type Manifest = components['schemas']['Manifest'];

const [service, key] = process.argv.slice(2);
const client = createClient<paths>({ baseUrl: service, headers: { Authorization: `Bearer ${key}` } });
const id = { path: { id: 'facecap' } };
let failed = 0;
const check = (what: string, ok: boolean) => {
  console.log(`${ok ? 'ok  ' : 'FAIL'} typed client: ${what}`);
  if (!ok) failed++;
};

async function main(): Promise<void> {
  // A bare mesh body: every member with a default stays optional.
  const mesh = await client.POST('/v1/rigs/{id}/mesh', { params: id, body: { weights: { jawOpen: 0.5 }, format: 'json' } });
  const meshJson = typeof mesh.data === 'object' ? mesh.data : undefined;  // The JSON of the answer's types.
  const primitives = meshJson?.primitives ?? [];
  check('POST mesh {weights, format} -> JSON primitives', mesh.response.status === 200 && primitives.length === 4);

  const render = await client.POST('/v1/rigs/{id}/render', {
    params: id, body: { weights: { jawOpen: 1 }, width: 64, height: 64, camera: { yaw: 20 }, format: 'png' }, parseAs: 'arrayBuffer',
  });
  const bytes: unknown = render.data;  // The document's binary string, read as bytes (parseAs).
  const png = new Uint8Array(bytes instanceof ArrayBuffer ? bytes : new ArrayBuffer(0));
  check('POST render -> a PNG', render.response.status === 200 && png[1] === 0x50 && png[2] === 0x4e && png[3] === 0x47);

  const sheet = await client.POST('/v1/rigs/{id}/sheet', {
    params: id, body: { cells: [{ weights: { jawOpen: 1 }, label: 'open' }, { label: 'rest' }], width: 48, height: 48 },
    parseAs: 'arrayBuffer',
  });
  const sheetBytes: unknown = sheet.data;  // Typed as the document's binary string; parsed as bytes.
  check('POST sheet -> an image', sheet.response.status === 200 && sheetBytes instanceof ArrayBuffer && sheetBytes.byteLength > 100);

  const speech = await client.POST('/v1/rigs/{id}/speech', { params: id, body: { text: 'Hello there.' } });
  const visemes = typeof speech.data === 'object' ? speech.data.visemes : [];
  check('POST speech {text} -> visemes', speech.response.status === 200 && visemes.some((v) => v.viseme === 'aa'));

  // The batch takes the render settings the document now declares (width, height, view, camera).
  const batch = await client.POST('/v1/rigs/{id}/batch', {
    params: id, body: { variants: [{ id: 'open', weights: { jawOpen: 1 } }], format: 'png', width: 32, height: 32, view: 'clay' },
  });
  check('POST batch {variants, format png, width, height, view} -> 202 and a job', batch.response.status === 202 &&
        typeof batch.data?.id === 'string');
  if (batch.data?.id) await client.DELETE('/v1/jobs/{job}', { params: { path: { job: batch.data.id } } });

  // A bundled manifest, GET and PUT back as it came: the document's Manifest holds every member.
  const manifest = await client.GET('/v1/rigs/{id}/manifest', { params: id });
  const got: Manifest | undefined = manifest.data;
  check('GET manifest -> the Manifest', manifest.response.status === 200 && got !== undefined && 'landmarks' in got);
  const upload = await client.PUT('/v1/rigs/{id}/manifest', { params: id, body: { ...(got ?? {}), name: 'Typed' } });
  check('PUT manifest (what GET gave, renamed) -> 200', upload.response.status === 200);
  if (got) await client.PUT('/v1/rigs/{id}/manifest', { params: id, body: got });

  const rig = await client.GET('/v1/rigs/{id}', { params: id });
  check('GET rig -> 52 shapes', rig.response.status === 200 && (rig.data?.shapes ?? []).length === 52);

  const weights = await client.POST('/v1/rigs/{id}/check', { params: id, body: { weights: { jawOpen: 0.4, mouthSmile_L: 0.2 } } });
  check('POST check -> sum 0.6', weights.response.status === 200 && Math.abs((weights.data?.sum ?? 0) - 0.6) < 1e-6);

  const target = meshJson;
  const fit = await client.POST('/v1/rigs/{id}/fit', { params: id, body: { target, bounded: true } });
  check('POST fit (the mesh at jawOpen 0.5) -> jawOpen 0.5', fit.response.status === 200 &&
        Math.abs((fit.data?.weights.jawOpen ?? 0) - 0.5) < 1e-3);
}

main().then(() => process.exit(failed ? 1 : 0), (e: unknown) => {
  console.log(`FAIL typed client: ${String(e)}`);
  process.exit(1);
});
