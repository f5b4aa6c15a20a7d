// Validates an OpenAPI document (npm: @seriousme/openapi-schema-validator); exit 0 when valid.
import { Validator } from "@seriousme/openapi-schema-validator";
import fs from "fs";
const result = await new Validator().validate(JSON.parse(fs.readFileSync(process.argv[2], "utf8")));
if (!result.valid) console.log(JSON.stringify(result.errors, null, 1).slice(0, 3000));
process.exit(result.valid ? 0 : 1);
