// A client generated from the server's own /openapi.json (npm: swagger-client, which builds each
// request from the document: paths, parameter styles, request bodies, security) calls every
// operation the document lists, and each answer is checked: status and body. An operation of the
// document with no case here fails the test, so a new route comes with its call.
// usage: node openapi_client_test.mjs SERVICE_URL API_KEY RIG_GLB
// Prints ok/FAIL lines like the shell tests; exit 1 on a failure.
import SwaggerClient from 'swagger-client';
import Ajv2020 from 'ajv/dist/2020.js';
import addFormats from 'ajv-formats';
import fs from 'node:fs';

const [service, key, glbPath] = process.argv.slice(2);
let pass = 0, fail = 0;
const check = (what, cond) => { if (cond) { pass++; console.log('ok   ' + what); } else { fail++; console.log('FAIL ' + what); } };

const spec = await (await fetch(service + '/openapi.json')).json();
spec.servers = [{ url: service }];

// Each answer against the document (JSON Schema 2020-12, as OpenAPI 3.1 says): its status declared for the
// operation, its content type declared for that status, a JSON body valid against that content's schema,
// and every Facespace-* header (and Location, ETag) declared. The reasons it does not conform, if any.
const ajv = new Ajv2020({ strict: false, allErrors: true });
addFormats(ajv);
ajv.addSchema({ $id: 'facespace-openapi', components: spec.components });
const rooted = (schema) => JSON.parse(JSON.stringify(schema).replaceAll('"#/components/', '"facespace-openapi#/components/'));
function nonConformance(op, r) {
  const operation = spec.paths[op.path][op.method];
  const declared = operation.responses[String(r.status)] || operation.responses.default;
  if (!declared) return [`status ${r.status} is not declared (${Object.keys(operation.responses).join(', ')})`];
  const out = [];
  const type = (r.headers['content-type'] || '').split(';')[0].trim();
  const text = typeof r.text === 'string' ? r.text : '';
  if (declared.content) {
    const media = declared.content[type];
    if (!media) out.push(`${r.status} ${type || '(no type)'} is not declared (${Object.keys(declared.content).join(', ')})`);
    else if (media.schema && /[/+]json$/.test(type) && text) {
      const validate = ajv.compile(rooted(media.schema));
      if (!validate(JSON.parse(text))) out.push(`${r.status} ${type} fails its schema: ${ajv.errorsText(validate.errors, { separator: '; ' }).slice(0, 300)}`);
    } else if (media['x-facespace-line'] && type === 'application/x-ndjson' && text) {
      // Each line of an ndjson answer against the line's schema.
      const validate = ajv.compile(rooted(media['x-facespace-line']));
      const bad = text.trim().split('\n').findIndex((line) => !validate(JSON.parse(line)));
      if (bad >= 0) out.push(`line ${bad + 1} of ${type} fails its schema: ${ajv.errorsText(validate.errors, { separator: '; ' }).slice(0, 300)}`);
    }
  } else if (text) {
    out.push(`${r.status} has a body the document does not declare`);
  }
  const headers = Object.keys(declared.headers || {}).map((h) => h.toLowerCase());
  for (const h of Object.keys(r.headers)) {
    if ((/^facespace-/.test(h) || h === 'location' || h === 'etag') && !headers.includes(h)) out.push(`header ${h} is not declared for ${r.status}`);
  }
  return out;
}
const client = await SwaggerClient({ spec, authorizations: { bearer: { value: key } } });
const glb = fs.readFileSync(glbPath);
const json = (r) => (typeof r.body === 'object' && r.body !== null && !(r.body instanceof ArrayBuffer) ? r.body : JSON.parse(r.text));

// Calls an operation by its id with the generated client; failures (4xx, 5xx) come back as responses.
// A GET whose kept-alive connection the server closed as the request went out (its idle timeout passed
// while this machine was busy) gets no answer at all ("fetch failed"): it is sent once more, as a client
// may retry an idempotent request then (RFC 9112, 9.3.1).
async function call(operationId, parameters = {}, extra = {}) {
  for (let attempt = 0; ; ++attempt) {
    try {
      const request = SwaggerClient.buildRequest({ spec, operationId, parameters, ...extra });
      const response = await client.execute({ operationId, parameters, ...extra });
      response.request = request;
      return response;
    } catch (e) {
      if (e.response) return e.response;
      const idempotent = ['GET', 'HEAD'].includes(SwaggerClient.buildRequest({ spec, operationId, parameters, ...extra }).method);
      if (attempt === 0 && idempotent && /fetch failed/.test(String(e.message))) continue;
      throw e;
    }
  }
}

// The document's own example of an operation: its parameters' examples and its body's. The cases send
// these (a case adds what only a running server knows: a job's id, an uploaded file, a mesh to fit).
function example(operationId) {
  for (const item of Object.values(spec.paths)) {
    for (const op of Object.values(item)) {
      if (op.operationId !== operationId) continue;
      const parameters = {};
      for (const p of op.parameters || []) if ('example' in p) parameters[p.name] = p.example;
      const ex = op.requestBody?.content?.['application/json']?.examples?.example;
      return { parameters, body: ex ? ex.value : undefined };
    }
  }
  throw new Error(`no operation ${operationId}`);
}
const examples = (operationId, extra = {}) => {
  const ex = example(operationId);
  return call(operationId, ex.parameters, { ...(ex.body !== undefined ? body(ex.body) : {}), ...extra });
};

const job = {};
const body = (b) => ({ requestBody: b, requestContentType: 'application/json' });
// Each operation of the document: how to call it, and what its answer must hold.
const cases = {
  healthz: [() => call('healthz'), (r) => r.status === 200 && json(r).status === 'ok'],
  readyz: [() => call('readyz'), (r) => r.status === 200 && json(r).rigs >= 1],
  metrics: [() => call('metrics'), (r) => r.status === 200 && /facespace_http_requests_total/.test(r.text)],
  openapi: [() => call('openapi'), (r) => r.status === 200 && json(r).openapi.startsWith('3.1')],
  listRigs: [() => call('listRigs'), (r) => r.status === 200 && json(r).rigs.some((x) => x.id === 'facecap' && x.shapes === 52)],
  getRig: [() => examples('getRig'), (r) => r.status === 200 && json(r).shapes[24].name === 'jawOpen'],
  putRig: [() => call('putRig', example('putRig').parameters, { requestBody: glb, requestContentType: 'model/gltf-binary' }),
           (r) => r.status === 201 && json(r).id === 'client-upload' && json(r).shapes === 52],
  // A bundled rig's manifest (regions, landmarks...): what a client GETs, edits and PUTs is the document's Manifest.
  getManifest: [() => examples('getManifest'), (r) => r.status === 200 && typeof json(r).shapes === 'object' && 'landmarks' in json(r)],
  putManifest: [() => examples('putManifest'),
                (r) => r.status === 200 && json(r).name === 'From the client'],
  // A generated HTTP client cannot upgrade: it is told so (426, problem+json naming the WebSocket).
  getLive: [() => examples('getLive'), (r) => r.status === 426 && /WebSocket/.test(r.text)],
  getTopology: [() => examples('getTopology'),
                (r) => r.status === 200 && json(r).primitives.length === 4 && json(r).primitives.every((p) => p.indices.length % 3 === 0)],
  // The weights as the document declares them (deepObject): w[jawOpen]=0.5 on the wire.
  getMesh: [() => examples('getMesh'),
            (r) => r.status === 200 && /w%5BjawOpen%5D=0.5/.test(r.request.url) && r.headers['facespace-weight-sum'] === '0.5' &&
                   json(r).primitives.length === 4],
  postMesh: [() => examples('postMesh'),
             (r) => r.status === 200 && json(r).warnings.some((w) => w.code === 'extrapolation')],
  checkWeights: [() => examples('checkWeights'),
                 (r) => r.status === 200 && Math.abs(json(r).sum - 0.6) < 1e-6 && json(r).warnings.length === 0],
  // An image route answers the type asked for (Accept); the client asks as its caller says.
  getRender: [() => examples('getRender', { responseContentType: 'image/png' }),
              (r) => r.status === 200 && /image\/png/.test(r.headers['content-type']) && /w%5BjawOpen%5D=1/.test(r.request.url)],
  postRender: [() => examples('postRender'),
               (r) => r.status === 200 && /image\/webp/.test(r.headers['content-type'])],
  postSheet: [() => examples('postSheet', { responseContentType: 'image/png' }),
              (r) => r.status === 200 && /image\/png/.test(r.headers['content-type'])],
  sampleSequence: [() => examples('sampleSequence'),
                   (r) => r.status === 200 && json(r).frames[0].weights.jawOpen === 0.5],
  streamSequence: [() => examples('streamSequence'),
                   (r) => r.status === 200 && r.text.trim().split('\n').length >= 100],
  reduceSequence: [() => examples('reduceSequence'),
                   (r) => r.status === 200 && json(r).kept === 2 && json(r).removed === 1],
  speak: [() => examples('speak'),
          (r) => r.status === 200 && json(r).source === 'espeak-ng' && json(r).visemes.some((v) => v.viseme === 'aa') && json(r).keys.length > 2],
  listVoices: [() => call('listVoices'), (r) => r.status === 200 && json(r).voices.some((v) => v.language === 'en-us')],
  // One frame of 468 points (an oval: the contract's walk; the service suite checks what a face's
  // frames come to): its key, and the head's turn.
  capture: [() => call('capture', { id: 'facecap' }, body({
              image: [640, 480],
              frames: [Array.from({ length: 468 }, (_, i) => [320 + 100 * Math.cos(i), 240 + 130 * Math.sin(i), 0])],
            })),
            (r) => r.status === 200 && json(r).keys.length === 1 && json(r).head.length === 1],
  fit: [async () => {
          const target = json(await examples('getMesh'));
          const ex = example('fit');
          return call('fit', ex.parameters, body({ ...ex.body, target }));
        },
        (r) => r.status === 200 && Math.abs(json(r).weights.jawOpen - 0.5) < 1e-3],
  startBatch: [() => examples('startBatch'),
               (r) => { job.id = r.status === 202 && json(r).links.self.split('/').pop(); return r.status === 202 && /^[0-9a-f]{32}$/.test(job.id); }],
  // FaceCap onto itself: its own 52 shapes kept, the visemes baked; the job writes facecap-derived.
  startDerive: [() => examples('startDerive'),
                async (r) => {
                  if (r.status !== 202 || json(r).kind !== 'derive') return false;
                  const self = json(r).links.self.split('/').pop();
                  let j = {};
                  for (let i = 0; i < 600 && !['done', 'failed', 'cancelled'].includes(j.state); ++i) {
                    if (i) await new Promise((ok) => setTimeout(ok, 100));
                    j = json(await call('getJob', { job: self }));
                  }
                  return j.state === 'done' && j.result.rig === 'facecap-derived' && j.result.kept.length === 52;
                }],
  listJobs: [() => call('listJobs'), (r) => r.status === 200 && json(r).jobs.some((j) => j.links.self.endsWith(job.id))],
  getJob: [async () => {
             let r;
             for (let i = 0; i < 200; ++i) {
               r = await call('getJob', { job: job.id });
               if (r.status !== 200 || ['done', 'failed', 'cancelled', 'lost'].includes(json(r).state)) break;
               await new Promise((ok) => setTimeout(ok, 100));
             }
             return r;
           },
           (r) => r.status === 200 && json(r).state === 'done' && json(r).done === 3],
  getJobManifest: [() => call('getJobManifest', { job: job.id }), (r) => {
                     const lines = r.status === 200 ? r.text.trim().split('\n').map((l) => JSON.parse(l)) : [];
                     job.file = lines.length ? lines[0].file : '';
                     return lines.length === 3 && /\.obj$/.test(job.file);
                   }],
  getJobFile: [() => call('getJobFile', { job: job.id, name: job.file }),
               async (r) => r.status === 200 && /^v /m.test(r.data instanceof Blob ? await r.data.text() : r.text)],
  getJobResults: [() => call('getJobResults', { job: job.id }), (r) => r.status === 200 && /application\/zip/.test(r.headers['content-type'])],
  deleteJob: [() => call('deleteJob', { job: job.id }), (r) => r.status === 204],
  deleteRig: [() => examples('deleteRig'), (r) => r.status === 204],
};

const operations = [];
for (const [path, item] of Object.entries(spec.paths)) {
  for (const [method, op] of Object.entries(item)) {
    if (['get', 'put', 'post', 'delete', 'patch'].includes(method)) operations.push({ id: op.operationId, method, path });
  }
}
const missing = operations.filter((o) => !cases[o.id]).map((o) => `${o.method.toUpperCase()} ${o.path} (${o.id})`);
check(`every operation of the document has a call here (${operations.length}; missing: ${missing.join(', ') || 'none'})`, missing.length === 0);
const stale = Object.keys(cases).filter((id) => !operations.some((o) => o.id === id));
check(`every call here is an operation of the document (stale: ${stale.join(', ') || 'none'})`, stale.length === 0);

// In the order of the cases: uploads before their manifest, the batch before its files, deletes last.
for (const [id, [run, holds]] of Object.entries(cases)) {
  const op = operations.find((o) => o.id === id);
  if (!op) continue;
  let r = null, error = '';
  try { r = await run(); } catch (e) { error = e.message; }
  let ok = false;
  if (r !== null) {
    try { ok = await holds(r); } catch (e) { error = e.message; }
  }
  check(`generated client: ${op.method.toUpperCase()} ${op.path} (${id}) -> ${r ? r.status : error}` +
        (ok || !r ? '' : ` ${error} ${typeof r.text === 'string' ? r.text.slice(0, 160) : r.headers['content-type']}`), ok);
  if (r) {
    const reasons = nonConformance(op, r);
    check(`  ... the answer is the document's${reasons.length ? ': ' + reasons.join(' | ') : ''}`, reasons.length === 0);
  }
}
console.log(`${pass} passed, ${fail} failed`);
process.exit(fail ? 1 : 0);
